"""A child process that reads a user's file with OpenCascade and sends the results back.

OpenCascade's IGES and STEP readers end the whole process on some damaged files, and its
parallel mesher starts a thread pool that a process forked afterwards inherits in a state
it cannot use (the child then waits forever). So every read of a user's file runs in a
child (ReaderProcess) started from a clean process:

- forked, when this process has a single thread (core.processes.fork_is_clean: nothing in
  it has meshed, no BLAS or GUI threads run), which is the command line's case;
- else a fresh interpreter (subprocess, the same Python and package, with the runtime
  settings of core.runtime), which is what a script that has meshed, the FreeCAD GUI's
  console or a batch worker gets.

The child runs a task (a generator function named by module and name, whose arguments
are plain data) and sends each frame it yields, pickled, through a pipe; a frame's STAGE
entry (or a frame of that entry alone) says what the child does next. An InputError of the task is sent as a frame and raised
in the parent with its message (another exception as a RuntimeError: a fault here). When the child ends before its last frame (an exit or a
signal), receive() raises ReaderDied naming the file, what the child was doing and the
likely cause. Nothing here imports numpy or FreeCAD.
"""
import os
import pickle
import select
import struct
import sys
import time

from ...core import runtime
from ...core.errors import InputError, ReaderDied

#: Key of a frame that only tells the parent what the child does next.
STAGE = "stage"
#: Keys of a frame that carries the task's InputError message, or another exception's
#: (a fault of this program, raised in the parent as such).
ERROR, INTERNAL = "error", "internal"
#: Readers' names by file extension, for the message of a child that died while reading.
READER_NAMES = {".igs": "IGES", ".iges": "IGES", ".stp": "STEP", ".step": "STEP", ".brep": "BRep"}
#: The folder that holds this hullprod_wb package (the fresh interpreter imports it from there).
PACKAGE_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))


def reader_name(path):
    """'IGES', 'STEP', 'BRep' (READER_NAMES, by extension), or 'file' for another extension,
    for the file at path: the reader named in a message."""
    return READER_NAMES.get(os.path.splitext(str(path))[1].lower(), "file")


#: Seconds OpenCascade's reader may take on a file: READ_TIME_BASE plus READ_TIME_PER_MB a
#: megabyte (files of hulls read in well under a second a megabyte here), unless
#: $HULLPROD_READ_TIME_LIMIT gives the limit.
READ_TIME_BASE = 30.0
READ_TIME_PER_MB = 30.0


def read_time_limit(path):
    """Seconds the reading of the file at path may take (READ_TIME_BASE, READ_TIME_PER_MB)."""
    env = os.environ.get("HULLPROD_READ_TIME_LIMIT")
    if env:
        try:
            return max(float(env), 0.0)
        except ValueError:
            pass
    try:
        size = os.path.getsize(path)
    except OSError:
        size = 0
    return READ_TIME_BASE + READ_TIME_PER_MB * size / 2.0 ** 20


def describe_status(status):
    """'exit 1' or 'signal 11, SIGSEGV' for a waitpid status."""
    if os.WIFSIGNALED(status):
        import signal
        n = os.WTERMSIG(status)
        try:
            return "signal %d, %s" % (n, signal.Signals(n).name)
        except ValueError:
            return "signal %d" % n
    return "exit %d" % (os.WEXITSTATUS(status) if os.WIFEXITED(status) else status)


def death_message(path, stage, status):
    """One line: the file, what OpenCascade did, the likely cause (see ReaderDied)."""
    how = describe_status(status)
    if stage is None:
        what = "OpenCascade's %s reader ended the process (%s)" % (reader_name(path), how)
    else:
        what = "OpenCascade ended the reading process while %s (%s)" % (stage, how)
    return "%s: %s; the file is probably damaged" % (path, what)


def python_interpreter():
    """The Python interpreter for a fresh reading process: this one, unless this process
    is not a Python executable (the FreeCAD GUI), then its installation's python3."""
    exe = sys.executable or ""
    if os.path.basename(exe).startswith("python") and os.access(exe, os.X_OK):
        return exe
    version = "python%d.%d" % sys.version_info[:2]
    for folder in (sys.exec_prefix, sys.base_exec_prefix, "/usr"):
        for name in (version, "python3"):
            candidate = os.path.join(folder, "bin", name)
            if os.access(candidate, os.X_OK):
                return candidate
    raise InputError("no Python interpreter found to start the reading process (looked beside %s)" % exe)


def _run_task(task, args, fh):
    """In the child: the task's frames, each sent as soon as it is made."""
    import importlib
    module, name = task
    try:
        for frame in getattr(importlib.import_module(module), name)(*args):
            send(fh, frame)
    except InputError as exc:
        send(fh, {ERROR: str(exc)})
    except Exception as exc:
        send(fh, {INTERNAL: "%s: %s" % (type(exc).__name__, " ".join(str(exc).split()))})


def child_main():
    """Entry point of a fresh reading interpreter: argv = [write fd, pickled (task, args) in hex]."""
    fd, payload = int(sys.argv[1]), bytes.fromhex(sys.argv[2])
    task, args = pickle.loads(payload)
    try:
        with os.fdopen(fd, "wb") as fh:
            _run_task(task, args, fh)
    except BrokenPipeError:  # the parent stopped listening
        pass
    os._exit(0)


class ReaderProcess:
    """task(*args) (task: (module name, function name) of a generator of picklable frames)
    run in a child started now from a clean process (see the module doc); path names the
    file for the message of a child that dies. receive() returns the next frame (None
    after the last one), ready() whether one has begun to arrive, close() stops and reaps
    the child."""

    def __init__(self, path, task, args):
        from ...core.processes import fork_is_clean
        self.path, self.stage = path, None
        self.deadline = time.monotonic() + read_time_limit(path)
        self.owner = os.getpid()
        self._pid, self._popen = None, None
        r, w = os.pipe()
        try:
            if fork_is_clean():
                pid = os.fork()
                if pid == 0:  # child: run the task, leave without the parent's exit handlers
                    code = 0
                    try:
                        os.close(r)
                        os.dup2(2, 1)  # whatever the libraries print never mixes with our stdout
                        with os.fdopen(w, "wb") as fh:
                            _run_task(task, args, fh)
                    except BrokenPipeError:  # the parent stopped listening
                        pass
                    except BaseException:  # nothing more can be sent: the parent sees the exit
                        code = 70
                    finally:
                        os._exit(code)
                self._pid = pid
            else:
                code = ("import sys; sys.path.insert(0, %r); "
                        "from hullprod_wb.brep.reading.reader_process import child_main; child_main()" % PACKAGE_ROOT)
                import subprocess
                payload = pickle.dumps((task, args), pickle.HIGHEST_PROTOCOL).hex()
                safe_path = ["-P"] if sys.version_info >= (3, 11) else []  # no current directory first
                self._popen = subprocess.Popen([python_interpreter()] + safe_path + ["-c", code, str(w), payload],
                                               pass_fds=(w,), stdin=subprocess.DEVNULL, stdout=2,
                                               env=runtime.environment())
        except BaseException:
            os.close(r)
            raise
        finally:
            os.close(w)
        # unbuffered: nothing of a later frame waits in a buffer where ready() cannot see it
        self._fh = os.fdopen(r, "rb", buffering=0)

    def ready(self):
        """Whether data from the child (or its end) is waiting to be read."""
        if self._fh is None:
            return True
        return bool(select.select([self._fh], [], [], 0.0)[0])

    def receive(self, last=False):
        """The next frame of the task; its STAGE entry sets stage (what the child does now:
        None while it reads the file), a frame of that entry alone is not returned. last:
        the task has no frame after this one. Raises the task's InputError, or ReaderDied
        when the child ended before sending the frame."""
        if os.getpid() != self.owner:
            raise RuntimeError("a reading process's frames are read only by the process that started it")
        while self._fh is not None:
            if self.stage is None:  # OpenCascade's reader: it may stall on a damaged file
                left = self.deadline - time.monotonic()
                if left <= 0 or not select.select([self._fh], [], [], left)[0]:
                    self.close()
                    raise ReaderDied("%s: OpenCascade's %s reader did not finish within %.0f s; the file is "
                                     "probably damaged (HULLPROD_READ_TIME_LIMIT sets the limit)"
                                     % (self.path, reader_name(self.path), read_time_limit(self.path)))
            frame = _receive(self._fh)
            if frame is None:
                status = self._reap()
                raise ReaderDied(death_message(self.path, self.stage, status))
            if STAGE in frame:  # what the child does after this frame
                self.stage = frame.pop(STAGE)
                if not frame:
                    continue
            if ERROR in frame or INTERNAL in frame:
                self.close()
                if ERROR in frame:
                    raise InputError(frame[ERROR])
                raise RuntimeError("in the reading process: %s" % frame[INTERNAL])
            if last:
                self.close()
            return frame
        return None

    def _reap(self):
        """Wait for the ended child; its waitpid status."""
        self._fh.close()
        self._fh = None
        status = 0
        if self._pid is not None:
            status = os.waitpid(self._pid, 0)[1]
            self._pid = None
        elif self._popen is not None:
            code = self._popen.wait()
            status = ((-code) & 0x7f) if code < 0 else (code & 0xff) << 8
            self._popen = None
        return status

    def close(self):
        """Stop (if still running) and reap the child."""
        from ...core.processes import reap
        if self._fh is not None:
            self._fh.close()
            self._fh = None
        if os.getpid() != self.owner:  # a forked worker holds a copy: the owner reaps it
            self._pid, self._popen = None, None
            return
        if self._pid is not None:
            reap(self._pid)
            self._pid = None
        if self._popen is not None:
            self._popen.kill()
            self._popen.wait()
            self._popen = None


def send(fh, obj):
    """Write obj, pickled, as one frame (8-byte length, then the bytes)."""
    data = pickle.dumps(obj, pickle.HIGHEST_PROTOCOL)
    fh.write(struct.pack("<q", len(data)) + data)
    fh.flush()


def _read_exactly(fh, n):
    """n bytes from the unbuffered file fh (fewer at its end)."""
    parts, left = [], n
    while left > 0:
        chunk = fh.read(min(left, 1 << 20))
        if not chunk:
            break
        parts.append(chunk)
        left -= len(chunk)
    return b"".join(parts)


def _receive(fh):
    head = _read_exactly(fh, 8)
    if len(head) < 8:
        return None
    n = struct.unpack("<q", head)[0]
    data = _read_exactly(fh, n)
    if len(data) < n:
        return None
    try:
        return pickle.loads(data)
    except Exception:  # a frame cut short by a dying child
        return None
