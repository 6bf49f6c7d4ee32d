"""Derivation cache: generated code and robot info on disk, keyed by content.

    key = sha256(robot file bytes, formulation, anadyn version, anadyn code)

The last part is a fingerprint of anadyn's own source files, so a new
version or a changed code generator never reuses stale code.  Entries live
in $ANADYN_CACHE_DIR, else $XDG_CACHE_HOME/anadyn, else ~/.cache/anadyn,
one file each, ``KEY.json``, and for what most runs do not read (the recursive
path's whole generated Python and C) a side file ``KEY.texts`` whose SHA-256
the entry holds (``store``, ``texts``); native libraries and their records in
the folder beside it, ``<cache folder>-native`` (``native_directory``).

What is stored there later runs as code, so (docs/explanation/security.md):

- folders are created 0700 and files 0600 whatever the umask, each file
  under a temporary name made with ``O_CREAT | O_EXCL | O_NOFOLLOW`` and
  renamed over its name (a rename replaces a planted symbolic link, it
  never writes through it);
- before anything is read, ``trusted_folder`` checks that the folder and
  every folder above it belong to the user (or root) and are not writable
  by others (a user's private group and sticky folders such as /tmp
  excepted): otherwise ``UntrustedCache``, one line naming the folder and
  the fix, exit 2;
- every file is opened with ``O_NOFOLLOW``, must be a regular file of the
  user's (or root's) that others cannot write, and carries the SHA-256 of
  its content on its first line (``seal``): a damaged, truncated, foreign
  or hostile file is a miss with a warning line, and the run rebuilds it.

A cache folder that cannot be created or written is skipped silently (the
cache only saves time).  Besides the entries, the folder keeps the bytecode of
generated code (``compiled``: marshalled code objects, sealed and checked as
every file, so loaded only from the user's own files).
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import stat
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from types import CodeType

from .. import __version__
from ..errors import ModelError

FORMAT = 3
#: the first line of every sealed file: this, the content's SHA-256 (hex), a newline
SEAL = b"anadyn-sha256 "
_DIGEST = 64
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_READ = os.O_RDONLY | _NOFOLLOW | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
_CREATE = (os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW | getattr(os, "O_CLOEXEC", 0)
           | getattr(os, "O_BINARY", 0))


class UntrustedCache(ModelError):
    """A cache folder that others could write: anadyn loads nothing from it (exit 2)."""


class Untrusted(Exception):
    """A cache file that is not the user's own regular file: ``str`` says why."""


def directory() -> Path:
    if os.environ.get("ANADYN_CACHE_DIR"):
        return Path(os.environ["ANADYN_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "anadyn"


def native_directory() -> Path:
    """Beside the derivation cache: <cache folder>-native (libraries and their records)."""
    base = directory()
    return base.with_name(base.name + "-native")


#: the files whose text makes the generated code: the modules and the C templates
SOURCES = ("*.py", "*.c.in", "*.c")


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """Hash of anadyn's own sources (SOURCES: names and contents)."""
    package = Path(__file__).parent
    digest = hashlib.sha256()
    for path in sorted({p for pattern in SOURCES for p in package.rglob(pattern)}):
        digest.update(str(path.relative_to(package)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def key(robot_digest: str, formulation: str) -> str:
    text = f"{FORMAT}|{robot_digest}|{formulation}|{__version__}|{code_fingerprint()}"
    return hashlib.sha256(text.encode()).hexdigest()


# ------------------------------------------------------------------ trust --

def _owner_problem(info: os.stat_result) -> str | None:
    """Why a folder or file with this stat is not the user's own (None: it is).
    Root's files are trusted too: root can change anything anyway."""
    if info.st_uid not in (_uid(), 0):
        return f"belongs to {_user_name(info.st_uid)}, not to you"
    if info.st_mode & stat.S_IWOTH:
        return f"is writable by others (mode {stat.S_IMODE(info.st_mode):04o})"
    if info.st_mode & stat.S_IWGRP and not _private_group(info.st_gid):
        return (f"is writable by the group {_group_name(info.st_gid)} "
                f"(mode {stat.S_IMODE(info.st_mode):04o})")
    return None


def _uid() -> int:
    return os.getuid() if hasattr(os, "getuid") else 0


def _private_group(gid: int) -> bool:
    """Whether ``gid`` is the user's own group (named after the user, no other
    member): group write there is harmless, as umask 002 systems make it."""
    try:
        import grp
        import pwd
        user = pwd.getpwuid(_uid())
        group = grp.getgrgid(gid)
    except (ImportError, KeyError):
        return False
    return (gid == user.pw_gid and group.gr_name == user.pw_name
            and set(group.gr_mem) <= {user.pw_name})


def _user_name(uid: int) -> str:
    try:
        import pwd
        return f"user {pwd.getpwuid(uid).pw_name} (uid {uid})"
    except (ImportError, KeyError):
        return f"uid {uid}"


def _group_name(gid: int) -> str:
    try:
        import grp
        return grp.getgrgid(gid).gr_name
    except (ImportError, KeyError):
        return f"gid {gid}"


def trusted_folder(folder: Path, create: bool) -> Path | None:
    """``folder`` if anadyn may read and write its cache files there; None when it
    does not exist (and ``create`` is false) or cannot be created.  Missing folders
    are created 0700.  UntrustedCache when others could change what is in it."""
    if not hasattr(os, "getuid"):                      # no owners to check (Windows)
        return folder if folder.is_dir() or (create and _make(folder)) else None
    try:
        info = os.stat(folder)
    except OSError:
        if not (create and _make(folder)):
            return None
        info = os.stat(folder)
    if not stat.S_ISDIR(info.st_mode):
        return None
    problem = _owner_problem(info)
    if problem:
        fix = ("remove it or run: chmod 700 " + str(folder) if "writable" in problem
               else "remove it or set ANADYN_CACHE_DIR to a folder of yours")
        raise UntrustedCache(f"cache folder {folder} {problem}; {fix}")
    problem = _path_problem(folder)
    if problem:
        raise UntrustedCache(f"cache folder {folder}: {problem}; set ANADYN_CACHE_DIR to a "
                             "folder only you can write")
    return folder


def _path_problem(folder: Path) -> str | None:
    """Why someone else could swap ``folder`` for another (None: no one can): a
    symbolic link of theirs on its path, or a folder above it (as written or as
    resolved) that is not the user's or root's, or that others can write; a
    sticky folder of the user's or root's (like /tmp) is fine."""
    written = folder.absolute()
    try:
        resolved = folder.resolve()
    except (OSError, RuntimeError):
        resolved = written
    for path in (written, *written.parents):
        try:
            info = os.lstat(path)
        except OSError:
            continue
        if stat.S_ISLNK(info.st_mode) and info.st_uid not in (_uid(), 0):
            return f"{path} is a symbolic link of {_user_name(info.st_uid)}"
    for parent in dict.fromkeys((*written.parents, *resolved.parents)):
        try:
            above = os.stat(parent)
        except OSError:
            continue
        if above.st_mode & stat.S_ISVTX and above.st_uid in (_uid(), 0):
            continue                        # others cannot rename the user's entries
        problem = _owner_problem(above)
        if problem:
            return f"the folder above it, {parent}, {problem}"
    return None


def _make(folder: Path) -> bool:
    """Create ``folder`` and the missing folders above it, each 0700; False if it cannot be."""
    missing = []
    for path in (folder, *folder.parents):
        if path.exists():
            break
        missing.append(path)
    try:
        for path in reversed(missing):
            try:
                os.mkdir(path, 0o700)
            except FileExistsError:         # another run made it meanwhile
                continue
            os.chmod(path, 0o700)
    except OSError:
        return False
    return folder.is_dir()


def _staged(folder: Path, name: str, data: bytes) -> Path:
    """A new file (0600) beside ``folder / name`` holding ``data``, made with
    O_EXCL | O_NOFOLLOW under a name no other run uses; OSError if it cannot be."""
    import secrets

    staged = folder / f".{name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
    fd = os.open(staged, _CREATE, 0o600)
    try:
        with os.fdopen(fd, "wb") as out:
            if hasattr(os, "fchmod"):
                os.fchmod(out.fileno(), 0o600)
            out.write(data)
    except BaseException:
        _remove(staged)
        raise
    return staged


def _remove(path: Path) -> None:
    try:
        os.remove(path)
    except OSError:
        pass


def write_private(folder: Path, name: str, data: bytes) -> Path:
    """Write ``data`` to ``folder / name`` (0600): a new file beside it, renamed
    over the name (which replaces a link planted there, never writes through it).
    OSError if it cannot be written."""
    staged = _staged(folder, name, data)
    try:
        os.replace(staged, folder / name)
    except BaseException:
        _remove(staged)
        raise
    return folder / name


def create_private(path: Path, data: bytes) -> None:
    """Create ``path`` (0600) holding ``data``, whole from the start (a new file
    linked to the name); FileExistsError if ``path`` exists, as a link too."""
    staged = _staged(path.parent, path.name, data)
    try:
        os.link(staged, path)           # our own new file: no link to follow
    finally:
        _remove(staged)


def read_private(path: Path) -> bytes | None:
    """The bytes of the user's own regular file ``path``; None if it does not exist.
    Untrusted if it is a link, not a regular file, someone else's or writable by others."""
    try:
        fd = os.open(path, _READ)
    except FileNotFoundError:
        return None
    except OSError as err:                  # ELOOP: a symbolic link; or unreadable
        raise Untrusted("is a symbolic link" if os.path.islink(path)
                        else f"cannot be read ({err.strerror})") from None
    with os.fdopen(fd, "rb") as stream:
        info = os.fstat(stream.fileno())
        if not stat.S_ISREG(info.st_mode):
            raise Untrusted("is not a regular file")
        problem = _owner_problem(info) if hasattr(os, "getuid") else None
        if problem:
            raise Untrusted(problem)
        return stream.read()


def seal(payload: bytes) -> bytes:
    return SEAL + hashlib.sha256(payload).hexdigest().encode() + b"\n" + payload


def unseal(data: bytes) -> bytes | None:
    """The payload of a sealed file, None if its SHA-256 does not match (damaged)."""
    head = len(SEAL) + _DIGEST
    if not data.startswith(SEAL) or data[head:head + 1] != b"\n":
        return None
    payload = data[head + 1:]
    return payload if hashlib.sha256(payload).hexdigest().encode() == data[len(SEAL):head] \
        else None


def warn(line: str) -> None:
    """One warning line (``anadyn: warning: ...``) on stderr, once per process."""
    from ..model.library import announce
    announce(f"warning: {line}", warning=True)


def _read_sealed(folder: Path, name: str, what: str, decode, kind: str,
                 digest: str | None = None):
    """``decode`` of the payload sealed in ``folder / name``; None if there is none.
    A file that is damaged, foreign or not ``kind`` (``decode`` raises ValueError),
    or whose payload's SHA-256 is not ``digest`` (when given: another file's), is
    None too, with a warning naming it as ``what`` (it is rebuilt)."""
    path = folder / name
    try:
        data = read_private(path)
    except Untrusted as why:
        warn(f"{what} {path} {why}; not used, rebuilt")
        return None
    if data is None:
        return None
    if digest is not None and data[len(SEAL):len(SEAL) + _DIGEST] != digest.encode():
        warn(f"{what} {path} is not the one its cache entry names (its SHA-256 differs: "
             "another entry's or an older one); not used, rebuilt")
        return None
    payload = unseal(data)
    try:
        if payload is None:
            raise ValueError
        return decode(payload)
    except (ValueError, EOFError, TypeError, RecursionError, MemoryError):
        warn(f"{what} {path} is damaged (its content does not match its SHA-256 "
             f"or is not {kind}); not used, rebuilt")
        return None


def read_record(folder: Path, name: str, what: str, digest: str | None = None):
    """The JSON value sealed in ``folder / name``; None if there is none.  A file
    that is damaged, foreign, not JSON or (given ``digest``) not the one whose
    payload has that SHA-256 is None too, with a warning naming it as ``what`` (it
    is rebuilt)."""
    return _read_sealed(folder, name, what, json.loads, "JSON", digest)


def write_record(folder: Path, name: str, value) -> None:
    """Seal ``value`` as JSON into ``folder / name``; OSError if it cannot be written."""
    write_private(folder, name, seal(json.dumps(value).encode()))


# -------------------------------------------------------- derivation entries --

#: the file name ending of an entry's side file (``store``'s ``texts``)
TEXTS = ".texts"


def load(robot_digest: str, formulation: str) -> dict | None:
    """The stored entry (a mapping with the generated ``code``, or with ``texts``, the
    SHA-256 of its side file: ``texts``), or None on a miss."""
    folder = trusted_folder(directory(), create=False)
    if folder is None:
        return None
    entry = read_record(folder, f"{key(robot_digest, formulation)}.json", "cache entry")
    if (not isinstance(entry, dict) or entry.get("digest") != robot_digest
            or not isinstance(entry.get("code" if "texts" not in entry else "texts"), str)):
        return None
    return entry


def store(robot_digest: str, formulation: str, entry: dict, texts: dict | None = None) -> None:
    """File ``entry`` (JSON) as ``KEY.json``.  ``texts`` (names to strings), which
    most runs do not read, go to the side file ``KEY.texts`` (sealed, written
    first) and the entry keeps the SHA-256 of its payload, so that only the side
    file written with it is ever read back (``texts``)."""
    folder = trusted_folder(directory(), create=True)
    if folder is None:
        return
    name = key(robot_digest, formulation)
    try:
        if texts is not None:
            payload = json.dumps(texts).encode()
            write_private(folder, name + TEXTS, seal(payload))
            entry = {**entry, "texts": hashlib.sha256(payload).hexdigest()}
        write_record(folder, f"{name}.json", {**entry, "digest": robot_digest})
    except OSError:
        pass


def texts(robot_digest: str, formulation: str, entry: dict) -> dict | None:
    """The texts stored beside ``entry`` (``store``), read now; None, with a warning
    line, when its side file is missing, damaged, foreign or not the one the entry
    names (another entry's, an older one): the caller rebuilds them."""
    folder = trusted_folder(directory(), create=False)
    path = directory() / (key(robot_digest, formulation) + TEXTS)
    value = None if folder is None else read_record(folder, path.name, "cache side file",
                                                    entry["texts"])
    if value is None and folder is not None and not path.exists():
        warn(f"cache side file {path} is missing; rebuilt")
    if not (isinstance(value, dict) and all(isinstance(v, str) for v in value.values())):
        return None
    return value


# ------------------------------------------------------------ code objects --

#: whether generated code is compiled through the cache folder (``compiled``): only
#: inside ``keeping_code``, which ``build.numeric_model`` enters when the run uses the
#: derivation cache (library calls leave both off unless asked)
_KEEP_CODE: ContextVar[bool] = ContextVar("anadyn_keep_code", default=False)
#: the file name ending of a stored code object
CODE = ".code"


@contextmanager
def keeping_code(on: bool = True):
    """Inside the block, ``compiled`` keeps code objects in the cache folder (if ``on``)."""
    token = _KEEP_CODE.set(on)
    try:
        yield
    finally:
        _KEEP_CODE.reset(token)


def compiled(source: str, filename: str):
    """The code object of anadyn's generated ``source`` (``model.run_generated``).
    Inside ``keeping_code`` it is read from the cache folder, where an earlier run
    that compiled the same source under this Python left it (sealed, as every
    cache file: ``<SHA-256 of the bytecode magic and the source>.code``, its
    marshalled bytes), else compiled and left there; otherwise compiled."""
    if not _KEEP_CODE.get():
        return compile(source, filename, "exec")
    import marshal
    from importlib.util import MAGIC_NUMBER

    folder = trusted_folder(directory(), create=True)
    name = hashlib.sha256(MAGIC_NUMBER + filename.encode() + b"\0"
                          + source.encode("utf-8", "surrogatepass")).hexdigest() + CODE
    code = None if folder is None else _read_sealed(folder, name, "compiled code",
                                                    marshal.loads, "a code object")
    if not isinstance(code, CodeType):
        code = compile(source, filename, "exec")
        if folder is not None:
            try:
                write_private(folder, name, seal(marshal.dumps(code)))
            except OSError:
                pass
    return code
