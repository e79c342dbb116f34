"""A folder of results under keys (the BRep faces' store, brep.face_keys): atomic writes, a
checksum on every entry, least-recently-used eviction beyond a size bound.

An entry is one file, <folder>/<key[:2]>/<key>.entry: a header line with the format, the
key and the SHA-256 of the payload, then the payload (a pickle of the result). A reader
trusts an entry only when its header names the key asked for and the payload's digest
matches; anything else (a truncated write, a damaged disk block, a file of another version)
is counted, removed and read as a miss. A writer writes a temporary file in the same folder
and renames it over the entry (os.replace), so a reader sees the old entry, the new one or
none, and two writers of one key leave one whole entry; a run claims a key before making its
result (core.result_claims), so that runs sharing the store make it once. A hit refreshes the entry's
modification time; prune() removes the entries used longest ago until the folder fits its
bound. Write errors (a full disk, a folder that cannot be written) turn writing off for the
rest of the run and are recorded; they never change a result.

The entries are pickles: the folder is made readable and writable by its owner only, and a
folder others can write to must not be used.
"""
import errno
import hashlib
import os
import pickle
import time
from dataclasses import dataclass, field

from . import result_claims

#: The first bytes of an entry; a change of the entry format changes it.
FORMAT = b"HULLPROD-RESULT-1"
#: Default bound of a store's size in bytes (least recently used entries go beyond it).
DEFAULT_MAX_BYTES = 2 * 1024 ** 3
#: A temporary file older than this many seconds is a killed writer's, removed by prune().
STALE_TEMPORARY_S = 3600.0
#: Pickle protocol of the payloads (readable by every supported Python).
PICKLE_PROTOCOL = 4


@dataclass
class StoreCounts:
    """What a run did with its store: hits and misses (lookups), entries written, bytes read
    and written, entries found damaged (ignored and removed), write errors (messages;
    writing stops at the first), entries pruned, and results another run was making when
    this one missed them, waited for (result_claims)."""

    hits: int = 0
    misses: int = 0
    written: int = 0
    bytes_read: int = 0
    bytes_written: int = 0
    damaged: int = 0
    write_errors: list = field(default_factory=list)
    pruned: int = 0
    awaited: int = 0

    def to_dict(self):
        return {"hits": self.hits, "misses": self.misses, "written": self.written, "awaited": self.awaited,
                "bytes_read": self.bytes_read, "bytes_written": self.bytes_written,
                "damaged_entries_ignored": self.damaged, "write_errors": list(self.write_errors),
                "pruned": self.pruned}


class ResultStore:
    """Results under hexadecimal keys in folder (made on first write), at most max_bytes."""

    def __init__(self, folder, max_bytes=DEFAULT_MAX_BYTES):
        self.folder = os.path.abspath(os.fspath(folder))
        self.max_bytes = int(max_bytes)
        self.counts = StoreCounts()
        self.writable = True
        self.owner = result_claims.owner()
        self._shards = set()  # shard folders this run has made or found

    def path(self, key):
        return os.path.join(self.folder, key[:2], key + ".entry")

    def get(self, key, accept=None, count_miss=True):
        """The result stored under key, or None (absent, damaged or unreadable, or a result
        accept(result) refuses: a miss, counted when count_miss)."""
        path = self.path(key)
        data = _read(path)
        if data is None:
            self.counts.misses += count_miss
            return None
        value = self._decode(key, data)
        if value is None:
            self.counts.damaged += 1
            self.counts.misses += count_miss
            _remove(path)
            return None
        if accept is not None and not accept(value):
            self.counts.misses += count_miss
            return None
        self.counts.hits += 1
        self.counts.bytes_read += len(data)
        try:
            os.utime(path)  # most recently used
        except OSError:
            pass
        return value

    def holds(self, key, accept=None):
        """Whether a whole entry is under key that accept(result) takes (nothing counted)."""
        data = _read(self.path(key))
        value = None if data is None else self._decode(key, data)
        return value is not None and (accept is None or bool(accept(value)))

    def put(self, key, value):
        """Store value under key (atomically); False when writing is off or failed."""
        if not self.writable:
            return False
        payload = pickle.dumps(value, protocol=PICKLE_PROTOCOL)
        data = b"%s %s %s\n" % (FORMAT, key.encode("ascii"), hashlib.sha256(payload).hexdigest().encode("ascii"))
        data += payload
        path = self.path(key)
        tmp = "%s.tmp-%d-%d" % (path, os.getpid(), time.monotonic_ns())
        try:
            with self._created(tmp) as fh:
                fh.write(data)
            os.replace(tmp, path)
        except OSError as exc:
            _remove(tmp)
            self.writable = False
            self.counts.write_errors.append("%s: %s" % (errno.errorcode.get(exc.errno, "error"), exc.strerror or exc))
            return False
        self.counts.written += 1
        self.counts.bytes_written += len(data)
        return True

    def _created(self, tmp):
        """tmp opened for writing, its shard folder made first when this run has not made
        or found it yet (or it was removed since)."""
        shard = os.path.dirname(tmp)
        if shard not in self._shards:
            os.makedirs(shard, mode=0o700, exist_ok=True)
            self._shards.add(shard)
        try:
            return open(tmp, "wb")
        except FileNotFoundError:
            os.makedirs(shard, mode=0o700, exist_ok=True)
            return open(tmp, "wb")

    def made(self, key, make):
        """The result under key, else make()'s, stored under key (key None: make()'s, not
        stored)."""
        value = self.get(key) if key is not None else None
        if value is None:
            value = make()
            if key is not None:
                self.put(key, value)
        return value

    def claim(self, key):
        """Claim key for this run before making its result (core.result_claims): False while
        another live run is making it."""
        return result_claims.take(self.path(key), self.owner)

    def release(self, key):
        """Give up this run's claim on key (its result stored, or not to be made here)."""
        result_claims.release(self.path(key), self.owner)

    def claimed_elsewhere(self, key):
        """Whether another live run is making the result of key."""
        return result_claims.held_elsewhere(self.path(key), self.owner)

    def has_any(self, prefix):
        """Whether some entry's key starts with prefix (at least two characters): a cheap
        guess that a lookup may hit."""
        try:
            return any(n.startswith(prefix) for n in os.listdir(os.path.join(self.folder, prefix[:2])))
        except OSError:
            return False

    def entries(self):
        """[(mtime, size, path)] of the entries, and the stale temporary files removed."""
        out, now = [], time.time()
        try:
            shards = os.scandir(self.folder)
        except OSError:
            return out
        with shards:
            for shard in shards:
                if not shard.is_dir(follow_symlinks=False):
                    continue
                try:
                    files = list(os.scandir(shard.path))
                except OSError:
                    continue
                for f in files:
                    try:
                        st = f.stat(follow_symlinks=False)
                    except OSError:
                        continue
                    if f.name.endswith(".entry"):
                        out.append((st.st_mtime, st.st_size, f.path))
                    elif ".tmp-" in f.name and now - st.st_mtime > STALE_TEMPORARY_S:
                        _remove(f.path)
                    elif (f.name.endswith(result_claims.SUFFIX) or f.name.endswith(result_claims.OWNER_SUFFIX)) \
                            and now - st.st_mtime > result_claims.CLAIM_LIFETIME_S:
                        _remove(f.path)
        return out

    def size(self):
        """Bytes held by the entries."""
        return sum(s for _, s, _ in self.entries())

    def prune(self):
        """Remove the least recently used entries until the store holds at most max_bytes;
        returns how many were removed."""
        entries = sorted(self.entries())
        total = sum(s for _, s, _ in entries)
        removed = 0
        for _, size, path in entries:
            if total <= self.max_bytes:
                break
            if _remove(path):
                removed += 1
            total -= size
        self.counts.pruned += removed
        return removed

    @staticmethod
    def _decode(key, data):
        """The payload of an entry's bytes when its header names key and its digest matches
        (else None)."""
        end = data.find(b"\n", 0, 256)
        if end < 0:
            return None
        head = data[:end].split(b" ")
        if len(head) != 3 or head[0] != FORMAT or head[1] != key.encode("ascii"):
            return None
        payload = data[end + 1:]
        if hashlib.sha256(payload).hexdigest().encode("ascii") != head[2]:
            return None
        try:
            return pickle.loads(payload)
        except Exception:  # a payload of classes this version does not have: a miss
            return None


def _read(path):
    """The bytes of the file at path, None when it cannot be read."""
    try:
        with open(path, "rb") as fh:
            return fh.read()
    except OSError:
        return None


def _remove(path):
    try:
        os.unlink(path)
        return True
    except OSError:
        return False


def parse_size(text):
    """Bytes of a size given as a number with an optional K, M, G or T (powers of 1024)."""
    s = str(text).strip().upper().rstrip("B")
    scale = 1
    for i, unit in enumerate("KMGT"):
        if s.endswith(unit):
            s, scale = s[:-1], 1024 ** (i + 1)
            break
    try:
        value = float(s) * scale
    except ValueError:
        value = -1.0
    if not value >= 0:
        from .errors import InputError
        raise InputError("store size %r: give bytes, or a number with K, M, G or T" % text)
    return int(value)


#: The environment variable that names the BRep faces' store folder ("off": no store).
FOLDER_ENV = "HULLPROD_FACE_CACHE"
#: The environment variable that bounds its size (parse_size; default DEFAULT_MAX_BYTES).
SIZE_ENV = "HULLPROD_FACE_CACHE_SIZE"
#: Values of FOLDER_ENV that turn the store off.
OFF_VALUES = ("off", "none", "no", "0", "false")
#: The store's folder inside FreeCAD's user cache folder.
SUBFOLDER = os.path.join("HullProd", "faces")


def default_folder(user_cache=None):
    """The store's folder in FreeCAD's user cache folder (user_cache, as App.getUserCachePath
    gives it), else in $XDG_CACHE_HOME/FreeCAD/Cache (default ~/.cache)."""
    if not user_cache:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        user_cache = os.path.join(base, "FreeCAD", "Cache")
    return os.path.join(user_cache, SUBFOLDER)


def open_store(choice=None, user_cache=None):
    """(ResultStore or None, where it comes from): choice False (no store), a ResultStore,
    a folder, or None: $HULLPROD_FACE_CACHE (a folder, or "off"), else default_folder; its
    bound $HULLPROD_FACE_CACHE_SIZE, else DEFAULT_MAX_BYTES."""
    if choice is False:
        return None, "off (--no-cache, cache=False)"
    if isinstance(choice, ResultStore):
        return choice, "given"
    size = parse_size(os.environ[SIZE_ENV]) if os.environ.get(SIZE_ENV) else DEFAULT_MAX_BYTES
    if choice is not None:
        folder = os.fspath(choice)
        if os.path.exists(folder) and not os.path.isdir(folder):
            from .errors import InputError
            raise InputError("the faces' store %s is not a folder: give a folder (--cache DIR) or --no-cache"
                             % folder)
        return ResultStore(folder, size), "--cache"
    env = os.environ.get(FOLDER_ENV)
    if env is not None and env.strip().lower() in OFF_VALUES:
        return None, "off ($%s=%s)" % (FOLDER_ENV, env)
    if env:
        return ResultStore(env, size), "$" + FOLDER_ENV
    return ResultStore(default_folder(user_cache), size), "FreeCAD's user cache folder"
