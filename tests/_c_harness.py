"""The compiled-C test harness shared by the tests of the exported C laws and lookup tables.

One harness per kind of generated code, compiled with the strict flags every C test uses
(``cc -std=c99 -O2 -Wall -Wextra -Werror -pedantic ... -lm``), fed samples through a binary file of
little-endian doubles and read back the same way:

* :func:`compile_law` / :func:`run_law`: a law exported by :mod:`pgcomm.export.c` (PGNN or spline
  model, double or single precision, with or without the velocity of the direction term, with or
  without the feedforward). Per sample: the currents and their return code, the drive inputs and
  theirs, the model (gain, cogging), the direction force and the feedforward.
* :func:`compile_lut` / :func:`run_lut`: the lookup-table C of :func:`pgcomm.export.lut.lut_header`
  (float). Per sample: the return code and the currents.

The C compiler comes from the fixture ``cc`` of ``tests/conftest.py`` (one per test run).
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

#: the flags of every compiled-C test: C99, all warnings as errors, pedantic
CFLAGS = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic"]

LAW_HARNESS = r"""
#include <stdio.h>
#include <stdlib.h>
#include "@NAME@.h"

#define L @UNAME@_L
#define NIN (7 + 2 * L)
#define NOUT (2 + 10 * L + 3 + 3 + 2)
typedef @NAME@_real T;

/* in:  int32 n, then n records of doubles (y, v, f_star[3], k_hat[L], zeta_hat[L], r, a)
   out: n records (ret_currents, ret_drive, currents[L][2], fy[L], delta[L], gain[L][3][2],
        cogging[3], direction[3], g, u_ff) with u_ff from this record and the next (the last: itself);
        direction, g and u_ff are 0 where the law has no such function */
int main(int argc, char **argv)
{
    FILE *in, *out;
    int n, s, l, q, j;
    double *rec;
    if (argc != 3)
        return 1;
    in = fopen(argv[1], "rb");
    out = fopen(argv[2], "wb");
    if (!in || !out || fread(&n, sizeof n, 1, in) != 1)
        return 2;
    rec = malloc(sizeof(double) * NIN * (size_t)n);
    if (!rec || fread(rec, sizeof(double) * NIN, (size_t)n, in) != (size_t)n)
        return 3;
    for (s = 0; s < n; ++s) {
        const double *x = rec + NIN * s, *nx = rec + NIN * (s + 1 < n ? s + 1 : s);
        double res[NOUT];
        T y = (T)x[0], v = (T)x[1], f[3], k[L], z[L], cur[L][2], fy[L], de[L], g[L][3][2], cog[3], dir[3];
        int m = 0;
        (void)nx;
        for (q = 0; q < 3; ++q)
            f[q] = (T)x[2 + q];
        for (l = 0; l < L; ++l) {
            k[l] = (T)x[5 + l];
            z[l] = (T)x[5 + L + l];
        }
#if @UNAME@_HAS_VELOCITY
        res[m++] = @NAME@_currents(y, v, f, cur);
        res[m++] = @NAME@_drive_inputs(y, v, f, k, z, fy, de);
#else
        res[m++] = @NAME@_currents(y, f, cur);
        res[m++] = @NAME@_drive_inputs(y, f, k, z, fy, de);
        (void)v;
#endif
        dir[0] = dir[1] = dir[2] = (T)0;
        @DIRECTION@
        @NAME@_model(y, g, cog);
        for (l = 0; l < L; ++l)
            for (j = 0; j < 2; ++j)
                res[m++] = cur[l][j];
        for (l = 0; l < L; ++l)
            res[m++] = fy[l];
        for (l = 0; l < L; ++l)
            res[m++] = de[l];
        for (l = 0; l < L; ++l)
            for (q = 0; q < 3; ++q)
                for (j = 0; j < 2; ++j)
                    res[m++] = g[l][q][j];
        for (q = 0; q < 3; ++q)
            res[m++] = cog[q];
        for (q = 0; q < 3; ++q)
            res[m++] = dir[q];
        @FEEDFORWARD@
        if (fwrite(res, sizeof(double), (size_t)m, out) != (size_t)m)
            return 4;
    }
    free(rec);
    fclose(in);
    return fclose(out) != 0;
}
"""

#: the feedforward of the sample (g) and of the sample with the next one (u_ff): r and a are the record's last two
FEEDFORWARD = ("res[m++] = @NAME@_feedforward_g((T)x[5 + 2 * L], v, (T)x[6 + 2 * L]);\n"
               "        res[m++] = @NAME@_feedforward((T)x[5 + 2 * L], v, (T)x[6 + 2 * L],\n"
               "                                      (T)nx[5 + 2 * L], (T)nx[1], (T)nx[6 + 2 * L]);")
NO_FEEDFORWARD = "res[m++] = 0.0;\n        res[m++] = 0.0;"

LUT_HARNESS = r"""
#include <stdio.h>
#include "@NAME@.h"

#define L @UNAME@_L

/* in: int32 n, then n records of doubles (y, v, f_star[3]); out: n records (ret, currents[L][2]) */
int main(int argc, char **argv)
{
    FILE *in, *out;
    int n, s, l, q;
    if (argc != 3)
        return 1;
    in = fopen(argv[1], "rb");
    out = fopen(argv[2], "wb");
    if (!in || !out || fread(&n, sizeof n, 1, in) != 1)
        return 2;
    for (s = 0; s < n; ++s) {
        double x[5], res[1 + 2 * L];
        float y, v, f[3], cur[L][2];
        if (fread(x, sizeof(double), 5, in) != 5)
            return 3;
        y = (float)x[0];
        v = (float)x[1];
        for (q = 0; q < 3; ++q)
            f[q] = (float)x[2 + q];
        (void)v;
        res[0] = @CALL@;
        for (l = 0; l < L; ++l) {
            res[1 + 2 * l] = cur[l][0];
            res[2 + 2 * l] = cur[l][1];
        }
        if (fwrite(res, sizeof(double), 1 + 2 * L, out) != (size_t)(1 + 2 * L))
            return 4;
    }
    fclose(in);
    return fclose(out) != 0;
}
"""


def compile_c(cc: str, directory: Path, harness: str, *sources: Path, flags=()) -> Path:
    """Write ``harness`` as ``directory/harness.c``, compile it with ``sources`` under :data:`CFLAGS` and ``flags``
    (e.g. ``-ffast-math``), return the executable (the compiler's messages in the assertion if it fails)."""
    (directory / "harness.c").write_text(harness)
    exe = directory / "harness"
    proc = subprocess.run([cc, *CFLAGS, *flags, "-o", str(exe), str(directory / "harness.c"), *map(str, sources),
                           "-lm"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return exe


def run_records(exe: Path, records: np.ndarray, n_out: int) -> np.ndarray:
    """Feed ``records`` (n, k) to the harness as int32 n then doubles; its (n, n_out) doubles."""
    records = np.asarray(records, dtype="<f8")
    inp, outp = exe.parent / "in.bin", exe.parent / "out.bin"
    inp.write_bytes(np.int32(records.shape[0]).tobytes() + records.tobytes())
    subprocess.run([str(exe), str(inp), str(outp)], check=True)
    return np.fromfile(outp, "<f8").reshape(records.shape[0], n_out)


def compile_law(cc: str, directory: Path, name: str = "law", direction: str | None = None,
                feedforward: bool = False, flags=()) -> Path:
    """Compile the law harness against ``directory/name.c`` (already written by ``write_c``).

    ``direction``: the arguments of ``NAME_direction`` before its output (``"y, v"`` for a spline
    model, ``"v"`` for a PGNN with the direction term), or ``None`` (no direction output, zeros);
    ``feedforward``: the export has ``NAME_feedforward_g`` and ``NAME_feedforward``.
    """
    ff = FEEDFORWARD if feedforward else NO_FEEDFORWARD
    call = f"@NAME@_direction({direction}, dir);" if direction else ""
    text = (LAW_HARNESS.replace("@FEEDFORWARD@", ff).replace("@DIRECTION@", call)
            .replace("@NAME@", name).replace("@UNAME@", name.upper()))
    return compile_c(cc, directory, text, directory / f"{name}.c", flags=flags)


def run_law(exe: Path, L: int, y, f, k_hat, zeta_hat, v=None, r=None, a=None) -> dict:
    """Run the law harness on samples (positions m, demands N/N/N m, drive N/A and rad; velocities m/s and the
    feedforward's reference r (m) and acceleration a (m/s^2), zero where not given).

    Returns ``ret`` (n, 2: currents, drive inputs), ``currents`` (n, L, 2), ``fy``, ``delta`` (n, L),
    ``gain`` (n, L, 3, 2), ``cogging``, ``direction`` (n, 3), ``g``, ``u_ff`` (n,).
    """
    n = np.shape(y)[0]
    zero = np.zeros(n)
    col = lambda x: zero[:, None] if x is None else np.asarray(x, float)[:, None]  # noqa: E731
    rec = np.concatenate([col(y), col(v), np.asarray(f, float), np.asarray(k_hat, float),
                          np.asarray(zeta_hat, float), col(r), col(a)], axis=1)
    res = run_records(exe, rec, 2 + 10 * L + 3 + 3 + 2)
    c = 2
    out = {"ret": res[:, :2].astype(int), "currents": res[:, c:c + 2 * L].reshape(n, L, 2)}
    c += 2 * L
    out["fy"], out["delta"] = res[:, c:c + L], res[:, c + L:c + 2 * L]
    c += 2 * L
    out["gain"] = res[:, c:c + 6 * L].reshape(n, L, 3, 2)
    c += 6 * L
    out["cogging"], out["direction"] = res[:, c:c + 3], res[:, c + 3:c + 6]
    out["g"], out["u_ff"] = res[:, c + 6], res[:, c + 7]
    return out


def compile_lut(cc: str, directory: Path, name: str = "tab", velocity: bool = False, flags=()) -> Path:
    """Compile the lookup-table harness against ``directory/name.h`` (already written from ``lut_header``);
    ``velocity``: the table has a direction term (``NAME_currents(y, v, f, cur)``)."""
    call = f"{name}_currents(y, v, f, cur)" if velocity else f"{name}_currents(y, f, cur)"
    text = LUT_HARNESS.replace("@CALL@", call).replace("@NAME@", name).replace("@UNAME@", name.upper())
    return compile_c(cc, directory, text, flags=flags)


def run_lut(exe: Path, L: int, y, f, v=None) -> tuple[np.ndarray, np.ndarray]:
    """Run the lookup-table harness; returns the return codes (n,) and the currents (n, L, 2)."""
    n = np.shape(y)[0]
    vv = np.zeros(n) if v is None else np.asarray(v, float)
    out = run_records(exe, np.concatenate([np.asarray(y, float)[:, None], vv[:, None], np.asarray(f, float)], axis=1),
                      1 + 2 * L)
    return out[:, 0].astype(int), out[:, 1:].reshape(n, L, 2)
