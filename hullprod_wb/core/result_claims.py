"""Claims on a store's keys: which run is making a result now, so that runs sharing a store
(batch workers, Dask workers on one file system, two commands) make each result once.

A claim is a file <entry path>.claim made exclusively by the run that is about to make the
result; it holds the run's owner (host name and the process id of the run's main process:
the worker processes it forks share it) and is removed once the result is stored, or when
the run fails. The claim is a hard link to the run's owner file (<store>/runs/, made once a
run; its modification time refreshed at every claim), so that taking and releasing a claim
makes and frees no inode: a file system that must skip recently freed inodes when it makes
new ones (ext4) would otherwise pay at every entry for the claims released before it. Where
no hard link can be made (a file system without them, too many links), the claim is a file
of its own, created exclusively (O_CREAT | O_EXCL). Another run that finds a live claim on a
key it misses makes its other results first and then waits for the entry. A claim is dead,
and is taken over, when its owner's process on this host no longer runs, when it names
another host and is older than FOREIGN_CLAIM_S seconds, or after CLAIM_LIFETIME_S in any
case; so a killed run never blocks another for long, and at worst a result is made twice
(the same bits: a result depends on its key only). A claim that cannot be written (a
read-only folder) lets the run make the result itself.
"""
import hashlib
import os
import socket
import time

#: Seconds after which any claim is dead (a run making one result for longer is not waited for).
CLAIM_LIFETIME_S = 3600.0
#: Seconds after which a claim of another host is dead.
FOREIGN_CLAIM_S = 600.0
#: The suffix of a claim's file after the entry's path.
SUFFIX = ".claim"
#: The folder of the runs' owner files inside a store, and their suffix.
RUNS_FOLDER = "runs"
OWNER_SUFFIX = ".owner"


def owner(pid=None):
    """This run's owner text: host name and main process id."""
    return "%s %d" % (socket.gethostname(), os.getpid() if pid is None else pid)


def _pid_runs(pid):
    """Whether process pid of this host runs (an ended process its parent has not yet waited
    for, a zombie, does not)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process: it runs
        return True
    try:
        with open("/proc/%d/stat" % pid, "rb") as fh:
            return fh.read().rsplit(b")", 1)[-1].split()[0] != b"Z"
    except (OSError, IndexError):  # no /proc here: by the signal alone
        return True


def _read(path):
    """(owner text, the claim's age in seconds), or None when there is no claim."""
    try:
        with open(path, "r", encoding="ascii", errors="replace") as fh:
            text = fh.read(200).strip()
        age = time.time() - os.stat(path).st_mtime
    except OSError:
        return None
    return text, age


def is_live(text, age, host=None):
    """Whether a claim with owner text, made age seconds ago, still binds other runs."""
    if age > CLAIM_LIFETIME_S:
        return False
    parts = text.split()
    if len(parts) != 2 or not parts[1].isdigit():
        return age < FOREIGN_CLAIM_S  # a claim being written, or not ours to read: by its age
    if parts[0] == (host or socket.gethostname()):
        return _pid_runs(int(parts[1]))
    return age < FOREIGN_CLAIM_S


def owner_file(entry_path, me):
    """The path of the owner file of run me in the store of entry_path
    (<store>/<shard>/<key>.entry): <store>/runs/<digest of me>.owner."""
    store = os.path.dirname(os.path.dirname(entry_path))
    name = hashlib.sha256(me.encode("utf-8")).hexdigest()[:24] + OWNER_SUFFIX
    return os.path.join(store, RUNS_FOLDER, name)


def _linked(path, entry_path, me):
    """Try to make the claim path a hard link to run me's owner file (made when missing,
    whole or not at all): True when made, False when a claim is there already, None when no
    link can be made here."""
    src = owner_file(entry_path, me)
    for _ in range(3):  # the owner file and the claim's folder may both be missing
        try:
            os.link(src, path)
        except FileExistsError:
            return False
        except FileNotFoundError:
            if not os.path.exists(src):
                if not _made_owner_file(src, me):
                    return None
                continue
            try:
                os.makedirs(os.path.dirname(path), mode=0o700, exist_ok=True)
            except OSError:
                return None
            continue
        except OSError:  # no hard links here (or too many): a file of its own
            return None
        try:
            os.utime(src)  # the run is alive: its claims are recent
        except OSError:
            pass
        return True
    return None


def _made_owner_file(src, me):
    """Make run me's owner file src (atomically: written aside, then renamed); False when it
    cannot be made."""
    tmp = "%s.tmp-%d-%d" % (src, os.getpid(), time.monotonic_ns())
    try:
        os.makedirs(os.path.dirname(src), mode=0o700, exist_ok=True)
        with open(tmp, "w", encoding="ascii") as fh:
            fh.write(me + "\n")
        os.replace(tmp, src)
        return True
    except OSError:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        return False


def take(entry_path, me):
    """True when the run me now holds the claim on entry_path (made now, held already, taken
    over from a dead claim, or not writable here); False while another live run holds it."""
    path = entry_path + SUFFIX
    for _ in range(2):
        made = _linked(path, entry_path, me)
        if made is None:  # no link here: a file of its own
            made = _created(path, me)
        if made is None:
            return True  # no claim can be written here: no coordination, the run makes it
        if made:
            return True
        seen = _read(path)  # a claim is there
        if seen is None:
            continue  # released meanwhile: try again
        if seen[0] == me:
            return True
        if is_live(*seen):
            return False
        try:
            os.unlink(path)  # a dead claim
        except OSError:
            pass
    return True


def _created(path, me):
    """Create the claim path as a file of its own holding me (exclusively): True when made,
    False when a claim is there already, None when none can be written here."""
    try:
        os.makedirs(os.path.dirname(path), mode=0o700, exist_ok=True)
        fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
    except FileExistsError:
        return False
    except OSError:
        return None
    with os.fdopen(fd, "w", encoding="ascii") as fh:
        fh.write(me + "\n")
    return True


def held_elsewhere(entry_path, me):
    """Whether a live claim of another run is on entry_path."""
    seen = _read(entry_path + SUFFIX)
    return seen is not None and seen[0] != me and is_live(*seen)


def release(entry_path, me):
    """Remove the claim on entry_path if the run me holds it."""
    path = entry_path + SUFFIX
    seen = _read(path)
    if seen is not None and seen[0] == me:
        try:
            os.unlink(path)
        except OSError:
            pass
