"""Build, cache and load the recursive path's C (``emit``) as a CPython extension.

The compiler and its flags are Python's own (sysconfig: CC, CFLAGS, CCSHARED,
LDSHARED, EXT_SUFFIX; $CC chooses another compiler); a module with the
Jacobian compiles at FLAGS (-O1), the quick module of a cold run at
QUICK_FLAGS (-O0, ``QuickBuild``).

When: on a cache miss the run starts with the generated Python, the quick
module compiles on the other core and the run switches to it when it is built
(``models.RecursiveModel``), and the full library compiles in a detached process at
the lowest priority (``build_in_background``, ``compile_job``), into
``<cache folder>-native/``, named by a hash of its C source, the compile
command, the Python version and the extension suffix; the next run loads it
(``load``) once its bytes match the SHA-256 recorded beside it (a damaged,
truncated or foreign library never reaches the dynamic loader: a warning, and
it is rebuilt).  One build per library at a time: a ``.building`` marker holds
the builder's process id (a dead process's marker is stale).  A failed build
is remembered and said once, not retried.  ``ANADYN_NATIVE=wait`` compiles
before running, ``ANADYN_NATIVE=0`` never.  No compiler, no Python headers or a
failed compile: the generated Python runs.  What is checked before anything is
loaded: ``cache`` and docs/explanation/security.md.
"""
from __future__ import annotations

import hashlib
import importlib.machinery
import importlib.util
import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time
from pathlib import Path
from typing import Callable

from .. import cache, compile_job

#: -O1: as fast as -O2 on these straight-line kernels (measured: arm7 RHS 0.7-1.0 us
#: against 1.3-2.1 us), compiled in half the time; no fused multiply-add, so that the C
#: gives the bits of the generated Python
#: (after sysconfig's compile flags: ``command``)
FLAGS = ("-O1", "-fno-math-errno", "-ffp-contract=off")
#: the quick build of a cold run (forward dynamics only): unoptimized, it compiles in
#: a third of the time (chain12: 0.11 s against 0.25 s at -O1) and is still ~10x the
#: generated Python; no optimization level changes the IEEE arithmetic, so the bits too
QUICK_FLAGS = ("-O0", *FLAGS[1:])
#: sysconfig's CFLAGS left out: optimization and debug info (anadyn sets -O itself;
#: debug info only slows the compile), warnings, link-time optimization, profiling,
#: and unsafe math, which would change the bits
DROPPED_CFLAGS = ("-O", "-g", "-W", "-flto", "-fprofile", "-ffast-math", "-funsafe-math")
#: the C file's name in the private build folder
SOURCE = "module.c"
#: the native folder's record of the build failures already said (``failed_before``)
REPORTED = "failures-said.json"
#: the folder above ``anadyn_cli``: where the detached build imports compile_job from
ROOT = str(Path(__file__).resolve().parents[3])
_HEX = re.compile(r"[0-9a-f]{64}")


def _compiler_words() -> list[str] | None:
    """The C compiler's command: $CC, else the compiler Python was built with
    (sysconfig's CC), else cc; its program resolved on PATH; None if none is found."""
    for command in filter(None, (os.environ.get("CC"), sysconfig.get_config_var("CC"), "cc")):
        words = shlex.split(command)
        path = shutil.which(words[0]) if words else None
        if path:
            return [path, *words[1:]]
    return None


def compiler() -> str | None:
    """The C compiler's path (``_compiler_words``), or None."""
    words = _compiler_words()
    return words[0] if words else None


def python_include() -> str | None:
    include = sysconfig.get_paths().get("include")
    return include if include and Path(include, "Python.h").exists() else None


def flags(c_text: str) -> tuple[str, ...]:
    """FLAGS for a module with the Jacobian, for the generic kernel (``generic``) and
    for the regressor (``recursive.regressor``), QUICK_FLAGS for a quick one; and
    NumPy's headers (``_numpy_flags``) where the C includes them."""
    return _options(any(mark in c_text for mark in OPTIMIZED_MARKS), NUMPY_MARK in c_text)


def _options(optimized: bool, numpy: bool) -> tuple[str, ...]:
    chosen = FLAGS if optimized else QUICK_FLAGS
    return (*chosen, *_numpy_flags()) if numpy else chosen


#: in the C of a module compiled at FLAGS (``flags``)
OPTIMIZED_MARKS = ("anadyn_jac", "anadyn_generic", "anadyn_regressor")
#: in the C of a module that makes NumPy arrays (``recursive.derivatives``)
NUMPY_MARK = "#include <numpy/arrayobject.h>"


def _numpy_flags() -> tuple[str, ...]:
    """NumPy's headers, and its version as a define that no code reads: in the
    command, so that another NumPy names another module (built against its headers)."""
    import numpy

    return (f"-I{numpy.get_include()}", f"-DANADYN_NUMPY_VERSION={numpy.__version__}")


def _config(name: str) -> list[str]:
    return shlex.split(sysconfig.get_config_var(name) or "")


def command(options: tuple[str, ...]) -> list[str]:
    """The compile-and-link line of a CPython extension, as Python's own build
    configuration gives it (sysconfig): the compiler (``_compiler_words``),
    CFLAGS less DROPPED_CFLAGS, CCSHARED, ``options``, the Python headers, SOURCE
    into ``compile_job.OUTPUT`` (run in the build folder), LDSHARED's flags
    (-shared; -bundle on macOS) and -lm."""
    cc, base = _compiler_words() or ["cc"], _config("CC")
    ldshared = _config("LDSHARED")
    link = ldshared[len(base):] if base and ldshared[:len(base)] == base else ldshared[1:]
    if not {"-shared", "-bundle", "-dynamiclib"} & set(link):
        link.insert(0, "-shared")
    cflags = [f for f in _config("CFLAGS") if not f.startswith(DROPPED_CFLAGS)]
    return [*cc, *cflags, *(_config("CCSHARED") or ["-fPIC"]), *options, "-DANADYN_PYEXT",
            f"-I{python_include()}", SOURCE, "-o", compile_job.OUTPUT, *link, "-lm"]


def suffix() -> str:
    """The file name ending of an extension module here (sysconfig's EXT_SUFFIX)."""
    return (sysconfig.get_config_var("EXT_SUFFIX")
            or importlib.machinery.EXTENSION_SUFFIXES[0])


def module_name(c_text: str) -> str:
    """Named by a hash of the C text's SHA-256, the whole compile command, Python's
    version and the extension suffix (``named`` of its ``signature``)."""
    return named(signature(c_text))


def signature(c_text: str) -> dict:
    """What names the module of ``c_text`` besides this machine's compiler, NumPy
    and Python (``named``): the text's SHA-256 and which flags it compiles at
    (``flags``).  A few bytes, which the derivation cache entry keeps, so that a
    warm run finds its library without reading (or hashing) the text."""
    return {"sha256": hashlib.sha256(c_text.encode()).hexdigest(),
            "optimized": any(mark in c_text for mark in OPTIMIZED_MARKS),
            "numpy": NUMPY_MARK in c_text}


def named(text: dict) -> str:
    """The module name of the C text whose ``signature`` is ``text``, under the
    compile command, Python and extension suffix of this run (so another compiler,
    flag, NumPy or Python names another library).  ValueError for a malformed one."""
    if not (isinstance(text, dict) and isinstance(text.get("sha256"), str)
            and _HEX.fullmatch(text["sha256"]) and isinstance(text.get("optimized"), bool)
            and isinstance(text.get("numpy"), bool)):
        raise ValueError("not a C text's signature")
    line = " ".join(command(_options(text["optimized"], text["numpy"])))
    key = "|".join([text["sha256"], line, sys.version, suffix()])
    return "_anadyn_" + hashlib.sha256(key.encode()).hexdigest()[:24]


def folder() -> Path:
    """Beside the derivation cache: <cache folder>-native (``cache.native_directory``)."""
    return cache.native_directory()


def library_path(c_text: str, name: str | None = None) -> Path | None:
    """The cached library built from ``c_text`` (its ``module_name``, when the caller
    has it: a robot's C text is megabytes to hash), its bytes checked against the
    SHA-256 of its record; None when there is none, or (with a warning) when it
    is damaged, missing or not the user's: the caller rebuilds it.
    UntrustedCache when the folder is not the user's own."""
    place = cache.trusted_folder(folder(), create=False)
    if place is None:
        return None
    name = name or module_name(c_text)
    record = cache.read_record(place, f"{name}.lib", "native library record")
    if record is None:
        return None
    digest = record.get("sha256") if isinstance(record, dict) else None
    if not (isinstance(digest, str) and _HEX.fullmatch(digest)):
        cache.warn(f"native library record {place / (name + '.lib')} is damaged; "
                   "not used, rebuilt")
        return None
    path = place / compile_job.library_name(name, digest, suffix())
    try:
        data = cache.read_private(path)
    except cache.Untrusted as why:
        cache.warn(f"native library {path} {why}; not used, rebuilt")
        return None
    if data is None or hashlib.sha256(data).hexdigest() != digest:
        cache.warn(f"native library {path} is " + ("missing" if data is None else
                   "damaged (its SHA-256 does not match its record)") + "; not used, rebuilt")
        return None
    return path


def failed_before(place: Path | None, name: str) -> str | None:
    """Why an earlier build of module ``name`` failed (None: none did).  Each
    reason is said once, in one warning line, by the first run that finds it
    (REPORTED keeps the reasons said); later runs use the generated Python
    without trying again (until the record is removed)."""
    if place is None:
        return None
    record = cache.read_record(place, f"{name}.failed", "native build record")
    if not (isinstance(record, dict) and isinstance(record.get("why"), str)):
        return None
    why = " ".join(record["why"].split())
    said = cache.read_record(place, REPORTED, "native build record")
    said = said if isinstance(said, list) else []
    if why not in said:
        cache.warn(f"native code not built: {why}; runs use the generated Python (the same "
                   f"results, slower); to try again, remove {place / '*.failed'}")
        try:
            cache.write_record(place, REPORTED, [*said, why][-100:])
        except OSError:
            pass
    return why


def mode() -> str:
    """ANADYN_NATIVE: "0" off; "wait" compile before running; otherwise
    (default) use a cached build, else build in the background for next time."""
    value = os.environ.get("ANADYN_NATIVE", "1").strip().lower()
    return {"0": "off", "off": "off", "no": "off", "wait": "wait", "sync": "wait"}.get(value, "auto")


def unavailable() -> str | None:
    """Why native code cannot be built here (None: it can)."""
    if compiler() is None:
        return "no C compiler found (set CC)"
    if python_include() is None:
        return "no Python.h (install the Python headers)"
    return None


def _work_folder(place: Path | None, c_text: str, name: str) -> Path:
    """A new private (0700) build folder holding the C file: inside the cache
    folder when there is one, so that the library is renamed into place."""
    work = None
    if place is not None:
        try:
            work = Path(tempfile.mkdtemp(prefix=".build-", dir=place))
        except OSError:
            pass
    work = work or Path(tempfile.mkdtemp(prefix="anadyn-cc-"))
    cache.write_private(work, SOURCE, c_text.replace("MODULE_NAME", f'"{name}"')
                        .replace("INIT_FUNCTION", f"PyInit_{name}").encode())
    return work


def build(c_text: str, timings: dict | None = None) -> tuple[object | None, str]:
    """Compile now (into the cache folder when it can be used) and load."""
    timings = {} if timings is None else timings
    why = unavailable()
    if why:
        return None, why
    name = module_name(c_text)
    place = cache.trusted_folder(folder(), create=True)
    start = time.perf_counter()
    try:
        work = _work_folder(place, c_text, name)
    except OSError as err:
        return None, f"cannot write the C file ({err.strerror or err})"
    try:
        path, note = compile_job.run(command(flags(c_text)), work, name, suffix(), place)
        if path is None:
            if failed_before(place, name) is None:      # not remembered: said here
                cache.warn(f"native code not built: {note}; this run uses the generated Python")
            return None, note
        module = _import(name, path)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    timings["native_compile"] = time.perf_counter() - start
    if module is None:
        return None, "the compiled module does not load"
    return module, "compiled"


def _claim(marker: Path) -> bool:
    """Create the build marker ``marker`` with this process's id, unless a build
    that is still alive holds it.  A marker whose process is gone (or older than
    ``compile_job.TIMEOUT``, or not a marker of the user's) is stale: replaced."""
    for _ in range(2):
        try:
            cache.create_private(marker, str(os.getpid()).encode())
            return True
        except FileExistsError:
            if not _stale(marker):
                return False
            try:
                os.remove(marker)
            except FileNotFoundError:
                pass
        except OSError:
            return False
    return False


def _stale(marker: Path) -> bool:
    try:
        data, info = cache.read_private(marker), os.lstat(marker)
    except (OSError, cache.Untrusted):
        return True
    if data is None or time.time() - info.st_mtime > compile_job.TIMEOUT:
        return True
    try:
        pid = int(data)
    except ValueError:
        return True
    return not _alive(pid)


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists (on Windows: assumed, the age bound decides)."""
    if pid <= 0:
        return False
    if os.name == "nt":
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:               # someone else's process
        return True
    except OSError:
        return False
    return True


def build_in_background(c_text: str, lowest_priority: bool = True):
    """Start the compiler in a detached process (``compile_job``) that leaves the
    library in the cache folder; one build per library at a time (the build
    marker), none after a failed one.  (note, the process or None)."""
    why = unavailable()
    if why:
        return why, None
    name = module_name(c_text)
    place = cache.trusted_folder(folder(), create=True)
    if place is None:
        return "cache folder not writable", None
    failed = failed_before(place, name)
    if failed:
        return f"native build failed before: {failed}", None
    marker = place / f"{name}.building"
    if not _claim(marker):
        return "being compiled in the background", None
    try:
        work = _work_folder(place, c_text, name)
    except OSError as err:
        compile_job.release(marker)
        return f"cache folder not writable ({err})", None
    script = ("import sys; sys.path.insert(0, sys.argv[1]); "
              "from anadyn_cli.numeric.compile_job import main; main(sys.argv[2:])")
    try:
        process = subprocess.Popen(
            [sys.executable, "-I", "-c", script, ROOT, str(place), name, suffix(), str(work),
             *command(flags(c_text))],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            start_new_session=True, close_fds=True,
            preexec_fn=_lowest_priority if lowest_priority and hasattr(os, "nice") else None)
    except OSError as err:
        shutil.rmtree(work, ignore_errors=True)
        compile_job.release(marker)
        return f"cannot start the compiler ({err})", None
    return "compiling in the background for the next run", process


class QuickBuild:
    """The forward dynamics alone (``recursive.forward``), compiled at QUICK_FLAGS
    while a cold run goes on: ``start`` launches the compiler (normal priority, on
    another core) or finds the library cached; ``module`` gives it once built,
    None before (a few microseconds a call: at most one ``poll`` per POLL seconds)."""

    POLL = 0.002

    def __init__(self, c_text: str, process, module=None):
        self.c_text, self.process, self._module = c_text, process, module
        self._next = 0.0

    @classmethod
    def start(cls, c_text: str | None) -> "QuickBuild | None":
        """None when native code is off or cannot be built here."""
        if c_text is None or mode() != "auto" or unavailable():
            return None
        path = library_path(c_text)
        if path is not None:
            module = _import(module_name(c_text), path)
            if module is not None:
                return cls(c_text, None, module)
        _, process = build_in_background(c_text, lowest_priority=False)
        return cls(c_text, process) if process is not None else None

    def module(self):
        if self._module is not None or self.process is None:
            return self._module
        now = time.perf_counter()
        if now < self._next:
            return None
        self._next = now + self.POLL
        if self.process.poll() is None:
            return None
        self.process = None                      # built or failed: no more polls
        path = library_path(self.c_text)
        if path is None:
            failed_before(cache.trusted_folder(folder(), create=False),
                          module_name(self.c_text))
            return None
        self._module = _import(module_name(self.c_text), path)
        return self._module


def _lowest_priority() -> None:
    """In the compiler's process: yield the CPU to the run that started it."""
    try:
        os.nice(19)
    except OSError:
        pass


def load(c_text: str | Callable[[], str], timings: dict | None = None,
         how: str | None = None, name: str | None = None):
    """(module, note): the library built from ``c_text`` if cached (and whole);
    else, by ``how`` ("auto", "wait", "off"; default ``mode()``), build it in the
    background (module None: this run uses the generated Python) or now; neither
    after a failed build.  With ``name``, the module's (``named``), ``c_text`` may
    be a function that gives the text, called only to build it: a warm run
    loads its library without the text."""
    timings = {} if timings is None else timings
    how = how or mode()
    if how == "off":
        return None, "native code off (ANADYN_NATIVE=0)"
    why = unavailable()
    if why:
        return None, why
    name = name or module_name(c_text)
    path = library_path(c_text, name)
    if path is not None:
        module = _import(name, path)
        if module is not None:
            timings["native"] = "cached"
            return module, "cached"
    failed = failed_before(cache.trusted_folder(folder(), create=False), name)
    if failed:
        return None, f"native build failed before: {failed}"
    c_text = c_text() if callable(c_text) else c_text
    if how == "wait":
        return build(c_text, timings)
    return None, build_in_background(c_text)[0]


def _import(name: str, path: Path):
    """The extension module ``name`` from the library file ``path`` (checked by the caller)."""
    try:
        loader = importlib.machinery.ExtensionFileLoader(name, str(path))
        spec = importlib.util.spec_from_file_location(name, path, loader=loader)
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
        return module
    except (ImportError, OSError):
        return None
