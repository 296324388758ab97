"""CasADi functions compiled to C once per installed version, cached in the user's cache directory.

CasADi generates the C source of a function (``CodeGenerator``); the system's C compiler makes a
shared library of it, written atomically into::

    $CASADI_SINS_CACHE | $XDG_CACHE_HOME | ~/.cache  /  casadi-sins / casadi-<version> / <tag>-<sha256>.so

and ``casadi.external`` loads it.  The library's name hashes the package's source, the CasADi
version, the compiler flags and the caller's key, so a later process (or a Monte Carlo worker) finds
it and only loads it (a few ms) without building the function again; concurrent workers may compile
the same library at once, and the last rename wins with identical content.  Without a C compiler, or
when compiling fails, the CasADi functions run on CasADi's virtual machine (the same numbers, slower)
and one line on standard error says so, once per process; ``CASADI_SINS_NO_COMPILE=1`` forces that.

:class:`StepChain` runs a per-row step ``(x, const, data row) -> (x next, const, out row)`` over many
rows in compiled blocks, through CasADi's zero-copy buffers (converting large NumPy arrays to ``DM``
and back costs more than the compiled work itself).  Nothing here knows what the functions compute.
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Callable

import casadi as ca
import numpy as np

#: Compiler flags: -O1 runs these straight-line functions as fast as -O2/-O3 and compiles in half the time.
CFLAGS = ("-O1", "-fPIC", "-shared")
#: Environment: the cache folder, and a switch forcing CasADi's virtual machine (tests of the fallback).
CACHE_VARIABLE = "CASADI_SINS_CACHE"
NO_COMPILE_VARIABLE = "CASADI_SINS_NO_COMPILE"
_NOTES: set[str] = set()


def cache_dir() -> Path:
    """The folder of the compiled libraries of this CasADi version."""
    base = os.environ.get(CACHE_VARIABLE) or os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "casadi-sins" / f"casadi-{ca.__version__}"


def find_compiler() -> str | None:
    """The C compiler: ``$CC``, else ``cc``, ``gcc`` or ``clang`` on the path; ``None`` if there is none."""
    for name in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def compiling() -> bool:
    """Whether functions are compiled at all (``CASADI_SINS_NO_COMPILE`` unset or empty)."""
    return not os.environ.get(NO_COMPILE_VARIABLE)


def note(message: str) -> None:
    """Print ``casadi-sins: message`` on standard error, once per process."""
    if message not in _NOTES:
        _NOTES.add(message)
        print(f"casadi-sins: {message}", file=sys.stderr)


@functools.lru_cache(maxsize=None)
def source_digest() -> str:
    """A hash of the package's source (every module): a change of any formula compiles anew."""
    digest = hashlib.sha256()
    for path in sorted(Path(__file__).resolve().parents[1].rglob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _compile(source: str, library: Path) -> str | None:
    """Compile C ``source`` into ``library`` (atomically); an error message, or ``None`` on success."""
    compiler = find_compiler()
    if compiler is None:
        return "no C compiler found (cc, gcc, clang or $CC)"
    library.parent.mkdir(parents=True, exist_ok=True)
    fd, c_file = tempfile.mkstemp(suffix=".c", dir=library.parent)
    os.close(fd)
    so_file = c_file[:-2] + ".so"
    try:
        Path(c_file).write_text(source)
        done = _run_compiler([compiler, *CFLAGS, "-o", so_file, c_file])
        if done.returncode:
            said = " ".join((done.stderr or done.stdout or "").split())[:200]
            return (f"compiling with {compiler} failed (exit status {done.returncode}"
                    + (f": {said})" if said else ", no message)"))
        os.replace(so_file, library)  # atomic: parallel workers may compile the same library
        return None
    except OSError as exc:
        return f"compiling with {compiler} failed ({exc.strerror or exc})"
    finally:
        for path in (c_file, so_file):
            if os.path.exists(path):
                os.remove(path)


def _run_compiler(command: list[str]) -> subprocess.CompletedProcess:
    """Run the C compiler in a session of its own (the terminal's Ctrl-C is this process's to handle); when
    this process is interrupted, the compiler and the programs it started (cc1, as) are killed with it."""
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    try:
        out, err = process.communicate()
    except BaseException:
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except OSError:
            pass
        process.wait()
        raise
    return subprocess.CompletedProcess(command, process.returncode, out, err)


def _generate(functions: list[ca.Function], tag: str) -> str:
    with tempfile.TemporaryDirectory() as folder:
        generator = ca.CodeGenerator(f"{tag}.c", {"with_header": False})
        for function in functions:
            generator.add(function)
        generator.generate(folder + os.sep)
        return Path(folder, f"{tag}.c").read_text()


def _load(names: list[str], library: Path) -> list[ca.Function] | None:
    try:
        return [ca.external(name, str(library)) for name in names]
    except RuntimeError:  # a damaged or foreign library: compile it again
        return None


def cached_functions(tag: str, key: str, names: list[str], build: Callable[[], list[ca.Function]]
                     ) -> list[ca.Function]:
    """The functions ``names`` compiled, loaded from the cache when there, else built and compiled now.

    Parameters
    ----------
    tag : str
        Start of the library's file name.
    key : str
        What the functions depend on beyond the package's source (their sizes, a sparsity pattern).
    names : list of str
        Names of the functions ``build`` returns, in order.
    build : callable
        ``build()`` returns the CasADi functions (called only when the library is not cached).

    Returns
    -------
    list of casadi.Function
        Loaded from the compiled library, or the built functions themselves (CasADi's virtual machine)
        when compiling is switched off, there is no C compiler, or it fails (one note on standard error).
    """
    if not compiling():
        note(f"{NO_COMPILE_VARIABLE} is set: the functions run on CasADi's virtual machine, not compiled (the same "
             "results, about 1.5 times the time)")
        return build()
    digest = hashlib.sha256(f"{source_digest()}|{ca.__version__}|{CFLAGS}|{key}".encode()).hexdigest()[:16]
    library = cache_dir() / f"{tag}-{digest}.so"
    if library.exists():
        loaded = _load(names, library)
        if loaded is not None:
            return loaded
    functions = build()
    failure = _compile(_generate(functions, tag), library)
    if failure is not None:
        note(f"{failure}: CasADi's virtual machine computes instead (the same results, slower)")
        return functions
    return _load(names, library) or functions


def block_of(step: ca.Function, size: int, name: str) -> ca.Function:
    """``size`` steps chained: ``(x, const, data (d x size)) -> (x after the block, const, outputs)``.

    The outputs are the step's third output of every step side by side, or, when the step has two
    outputs, every state as one column per step (a matrix state ``(r, c)`` column-major in ``r c`` rows).
    """
    inner = step.mapaccum(f"{name}_inner", size, 2)
    x, const = ca.MX.sym("x", step.sparsity_in(0)), ca.MX.sym("const", step.sparsity_in(1))
    data = ca.MX.sym("data", step.size1_in(2), size)
    results = inner(x, const, data)
    every = results[2] if step.n_out() > 2 else ca.reshape(results[0], step.nnz_in(0), size)
    last = results[0][:, (size - 1) * step.size2_in(0):]
    return ca.Function(name, [x, const, data], [last, const, every], ["x", "const", "data"],
                       ["x_last", "const_next", "out"])


class StepChain:
    """A per-row step run over the rows of a data array in compiled blocks (module docstring).

    Parameters
    ----------
    tag, key : str
        The library's tag and cache key (:func:`cached_functions`).
    build_step : callable
        ``build_step()`` returns the step ``(x, const, data row) -> (x next, const, out row)`` (SX), called
        only when the library is not cached yet.
    block, blocks_per_call : int
        Rows per compiled block, blocks per call.
    """

    def __init__(self, tag: str, key: str, build_step: Callable[[], ca.Function], block: int = 50,
                 blocks_per_call: int = 8):
        name = f"{tag}_block{block}"
        self.block = cached_functions(tag, f"{key}|{block}", [name],
                                      lambda: [block_of(build_step(), block, name)])[0]
        self.rows_per_call = block * blocks_per_call
        self.chunk = self.block.mapaccum(f"{name}_chunk", blocks_per_call, 2)
        self.out_width = self.chunk.nnz_out(2) // self.rows_per_call

    def __call__(self, x0, const, data: np.ndarray, pad: np.ndarray | None = None):
        """Outputs (n, o) of the chain over the ``n`` rows of ``data`` from state ``x0``, and the final state.

        The last call is padded with ``pad`` rows (default zeros): the final state is the state after the
        data only when ``pad`` is a step that changes nothing.
        """
        n, width = data.shape
        per_call = self.rows_per_call
        calls = max(1, -(-n // per_call))
        padded = np.zeros((calls * per_call, width))
        padded[:n] = data
        if pad is not None:
            padded[n:] = pad
        out = np.empty((calls * per_call, self.out_width))
        x = np.array(np.asarray(x0, dtype=float).ravel(order="F"))
        const = np.ascontiguousarray(np.asarray(const, dtype=float).ravel(order="F"))
        blocks = per_call // self.block.size2_in(2)
        x_last = np.empty((blocks, x.size))  # column-major, block after block
        const_out = np.empty((blocks, const.size))
        buffer, run = self.chunk.buffer()
        buffer.set_arg(1, memoryview(const))
        buffer.set_res(0, memoryview(x_last))
        buffer.set_res(1, memoryview(const_out))
        for c in range(calls):
            buffer.set_arg(0, memoryview(x))
            buffer.set_arg(2, memoryview(padded[c * per_call:(c + 1) * per_call]))  # C-order rows = column-major
            buffer.set_res(2, memoryview(out[c * per_call:(c + 1) * per_call]))
            run()
            x = x_last[-1].copy()
        return out[:n], x


class Buffered:
    """A CasADi function called through its zero-copy buffer: NumPy arrays in, dense NumPy arrays out.

    Inputs are taken as their column-major values (dense inputs); outputs come back with the function's
    shapes, column-major like CasADi's.
    """

    def __init__(self, function: ca.Function):
        self.function = function
        self.buffer, self.run = function.buffer()
        self.out = [np.zeros(function.nnz_out(i)) for i in range(function.n_out())]
        self.where = []
        for i, values in enumerate(self.out):
            sparsity = function.sparsity_out(i)
            self.where.append(None if sparsity.is_dense() else np.array(sparsity.find(), dtype=np.int64))
            self.buffer.set_res(i, memoryview(values))

    def __call__(self, *args) -> list[np.ndarray]:
        """The outputs for ``args`` (NumPy arrays, one per input)."""
        keep = []
        for i, arg in enumerate(args):
            values = np.ascontiguousarray(np.asarray(arg, dtype=float).ravel(order="F"))
            if values.size != self.function.nnz_in(i):
                raise ValueError(f"input {i} of {self.function.name()}: {values.size} values, expected "
                                 f"{self.function.nnz_in(i)}")
            keep.append(values)
            self.buffer.set_arg(i, memoryview(values))
        self.run()
        outs = []
        for i, values in enumerate(self.out):
            rows, cols = self.function.size_out(i)
            dense = values.copy() if self.where[i] is None else np.zeros(rows * cols)
            if self.where[i] is not None:
                dense[self.where[i]] = values
            outs.append(dense.reshape(rows, cols, order="F"))
        return outs


class Mapped:
    """A function of one column evaluated over many columns, in calls of ``chunk`` columns through buffers
    (the map is built once; CasADi's virtual machine is fast enough for small functions).

    Parameters
    ----------
    function : casadi.Function
        One dense input column ``(d, 1)``, one dense output column ``(o, 1)``.
    chunk : int
        Columns per call.
    """

    def __init__(self, function: ca.Function, chunk: int = 1024):
        self.chunk = chunk
        self.width_in, self.width_out = function.nnz_in(0), function.nnz_out(0)
        self.buffer, self.run = function.map(chunk).buffer()
        self.arg = np.zeros(chunk * self.width_in)
        self.res = np.zeros(chunk * self.width_out)
        self.buffer.set_arg(0, memoryview(self.arg))
        self.buffer.set_res(0, memoryview(self.res))

    def __call__(self, rows: np.ndarray) -> np.ndarray:
        """The outputs (N, o) for inputs given as rows (N, d)."""
        rows = np.asarray(rows, dtype=float).reshape(-1, self.width_in)
        out = np.empty((len(rows), self.width_out))
        for start in range(0, len(rows), self.chunk):
            part = rows[start:start + self.chunk]
            self.arg[:part.size] = part.ravel()
            self.run()
            out[start:start + len(part)] = self.res[:len(part) * self.width_out].reshape(len(part), -1)
        return out
