"""The scripts ``pgcomm plan --drive moteus|odrive`` writes beside a rotary plan: they run its speed-loop runs on the
drive with the drive's own Python package and log what ``pgcomm identify`` reads, under the drive's own names.

Each module here is a standalone script (standard library and the drive's package only, no pgcomm): the plan writer
copies it into the plan folder as ``run_<drive>.py``, and it reads ``plan.json`` and ``references/*.csv`` beside
itself. The drive's package is imported when the script runs, not when it is imported or parsed, so that CI can
check the scripts without the drive's package and a missing package gives one clear line. The columns each writes
(``COLUMNS``) are the ones :data:`pgcomm.rotary.plan.DRIVE_COLUMNS` maps in ``columns.toml``.
"""

#: Script module per drive (file name in this package, without ``.py``).
SCRIPTS = {"moteus": "moteus_run", "odrive": "odrive_run"}
