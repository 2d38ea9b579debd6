"""The one error boundary every console command runs inside.

Expected failures become one line on stderr, ``<command>: <what went wrong>``, and an exit
code the shell can act on (:data:`EXIT_CODES`): bad usage or input (a missing or unreadable
path, a file that is not text, YAML that does not parse, a value out of range, a damaged
bag) exits 2; a run that started and failed exits 1; Ctrl-C exits 130 after saying what it
stopped. Anything else is a bug: its traceback is kept, followed by a line saying so.

Stop signals (:data:`STOP_SIGNALS`): SIGTERM (what systemd, Docker, Kubernetes and Slurm send)
and SIGHUP (a closed terminal) stop a command exactly as Ctrl-C does, through the same code
(a ``KeyboardInterrupt``, or the flag of a command that stops in order, :func:`on_stop_signals`);
the exit code is then 128 + the signal's number (130, 143, 129), as a shell reports it.

Project errors that mean "bad input" derive from :class:`ValueError` (``ScenarioError``,
``BagError``, ``CampaignError``, ``ParameterError``, ...), as do ``UnicodeDecodeError`` and
the errors of ``float('x')``; a failed run raises :class:`RunFailed` or another
:class:`RuntimeError`. An :class:`OSError` is a path's problem when it names the path;
one that names none (``io.UnsupportedOperation``) is unexpected.
"""
from __future__ import annotations

import functools
import math
import os
import select
import signal
import sys
import threading
import traceback
from pathlib import Path
from typing import Callable

#: exit code -> meaning, the table docs/usage.md shows
EXIT_CODES = {0: "success", 1: "the run or check failed (a node died or stalled, a bag differs, a run of the "
                                "campaign failed, a wait timed out)",
              2: "bad usage or input, refused before anything was changed", 130: "interrupted (Ctrl-C / SIGINT)",
              129: "stopped by SIGHUP (a closed terminal), as by Ctrl-C",
              141: "the output pipe was closed by its reader (e.g. | head): ended quietly",
              143: "stopped by SIGTERM (systemd, Docker, Kubernetes, Slurm, kill), as by Ctrl-C"}
EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130
EXIT_CLOSED_PIPE = 141   # 128 + SIGPIPE: what a shell reports for a reader that stopped reading
#: The signals that stop a command as Ctrl-C does (module docstring).
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
#: The stop signals this process received, in order (the exit code follows the last).
_received: list[int] = []
BUG_LINE = ("{prog}: this is a bug, not a problem with your input: please report it, with the traceback above and "
            "the command line, on the project's issue tracker (README.md)")


class UsageError(ValueError):
    """Bad usage or input (exit 2); the message names the file, option or parameter."""


class RunFailed(RuntimeError):
    """The command started and failed (exit 1)."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C, caught where the command knows what it stopped and kept (exit 130)."""


def on_stop_signals(handler: Callable[[int], None]) -> Callable[[], None]:
    """Call ``handler(signum)`` on each of :data:`STOP_SIGNALS` (noting the signal for the exit
    code), once per SIGTERM or SIGHUP; returns the function that puts the previous handlers
    back. Only the main thread receives signals: elsewhere nothing is installed."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None

    def noted(signum: int, _frame) -> None:
        # a SIGTERM or SIGHUP that came before: the stop is under way (Linux sends the
        # parent-death signal again each time a thread of the dead parent is gone); a repeated
        # Ctrl-C is the user's, and the handler decides (e.g. abort at once)
        repeat = signum != signal.SIGINT and signum in _received
        _received.append(signum)
        if not repeat:
            handler(signum)

    previous = {s: signal.getsignal(s) for s in STOP_SIGNALS}
    for s in STOP_SIGNALS:
        signal.signal(s, noted)

    def restore() -> None:
        for s, h in previous.items():
            signal.signal(s, signal.SIG_DFL if h is None else h)
    return restore


def raise_interrupt(_signum: int) -> None:
    """A stop signal raises ``KeyboardInterrupt``, as Python's own Ctrl-C does."""
    raise KeyboardInterrupt


def stop_signal() -> int:
    """The last stop signal received (SIGINT when none was: a KeyboardInterrupt raised in code)."""
    return _received[-1] if _received else signal.SIGINT


def _yaml_error() -> tuple[type[BaseException], ...]:
    try:
        import yaml
    except ImportError:  # pragma: no cover - yaml is a pinned dependency
        return ()
    return (yaml.YAMLError,)


def describe(exc: BaseException) -> str:
    """One line for an expected failure."""
    if isinstance(exc, OSError) and exc.filename is not None:
        return f"{exc.filename}: {exc.strerror or type(exc).__name__}"
    if isinstance(exc, UnicodeDecodeError):
        return f"not a text file ({exc.encoding} cannot decode byte {exc.start})"
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


def outcome(prog: str, exc: BaseException, interrupted: str) -> int:
    """Print the line for ``exc`` (a traceback and the bug line when it is unexpected); the exit code."""
    if isinstance(exc, KeyboardInterrupt):
        signum = stop_signal()
        how = "interrupted" if signum == signal.SIGINT else f"interrupted by {signal.Signals(signum).name}"
        print(f"{prog}: {how}: {str(exc) or interrupted}", file=sys.stderr)
        return 128 + signum
    if isinstance(exc, OSError) and exc.filename is not None or \
            not isinstance(exc, OSError) and isinstance(exc, (ValueError, *_yaml_error())):
        print(f"{prog}: {describe(exc)}", file=sys.stderr)
        return EXIT_USAGE
    if isinstance(exc, RuntimeError) and not isinstance(exc, (NotImplementedError, RecursionError)):
        print(f"{prog}: {describe(exc)}", file=sys.stderr)
        return EXIT_FAILED
    traceback.print_exception(exc)
    print(BUG_LINE.format(prog=prog), file=sys.stderr)
    return EXIT_FAILED


def stdout_closed() -> bool:
    """Whether the reader of stdout is gone (a broken pipe elsewhere, to a child, is not this)."""
    try:
        poll = select.poll()
        poll.register(sys.stdout.fileno(), select.POLLOUT)
        return any(events & (select.POLLERR | select.POLLHUP) for _, events in poll.poll(0))
    except (OSError, ValueError, AttributeError):  # stdout replaced by a non-file (a test's capture)
        return True


def closed_pipe() -> int:
    """The reader of stdout went away (``gimbal-bag info BAG | head -2``): end quietly, as
    ``cat`` does, with 128 + SIGPIPE. Later writes, the interpreter's own flush at exit
    included, go to /dev/null instead of raising again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # stdout replaced by a non-file (a test's capture)
        pass
    return EXIT_CLOSED_PIPE


def cli_boundary(prog: str, interrupted: str = "stopped before the end; nothing was kept") -> Callable:
    """Decorate a console ``main(argv) -> int``: expected failures become one line and an exit code."""
    def wrap(main: Callable[..., int]) -> Callable[..., int]:
        @functools.wraps(main)
        def bounded(*args, **kwargs) -> int:
            _received.clear()
            restore = on_stop_signals(raise_interrupt)
            try:
                code = main(*args, **kwargs)
                sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
                return code
            except BrokenPipeError as exc:
                return closed_pipe() if stdout_closed() else outcome(prog, exc, interrupted)
            except (SystemExit, GeneratorExit):
                raise
            except BaseException as exc:  # noqa: BLE001 - the one place every failure is sorted
                return outcome(prog, exc, interrupted)
            finally:
                restore()
        return bounded
    return wrap


def read_text(path: Path | str, what: str) -> str:
    """The text of ``path``; a missing, unreadable or non-text file is a :class:`UsageError` naming ``what``."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8")
    except IsADirectoryError:
        raise UsageError(f"{what} {path}: is a directory, not a file") from None
    except OSError as exc:
        raise UsageError(f"{what} {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise UsageError(f"{what} {path}: not a text file (byte {exc.start} is not UTF-8)") from None


def finite(value: float, option: str, minimum: float | None = None, strict: bool = False) -> float:
    """``value`` when finite (and >= / > ``minimum``); else a :class:`UsageError` naming ``option``."""
    if not math.isfinite(value):
        raise UsageError(f"{option} must be a finite number, got {value}")
    if minimum is not None and (value <= minimum if strict else value < minimum):
        raise UsageError(f"{option} must be {'>' if strict else '>='} {minimum:g}, got {value:g}")
    return value


def writable_dir(path: Path | str, option: str) -> Path:
    """``path`` as an output directory to create: refused when it exists or its parent cannot be written."""
    path = Path(path)
    if path.exists():
        raise UsageError(f"{option} {path}: already exists; not overwriting it")
    return creatable(path, option)


def creatable(path: Path | str, option: str) -> Path:
    """``path`` when it (with any missing folders above it) can be created: its nearest existing
    ancestor is a writable directory; else a :class:`UsageError` naming ``option``."""
    path = Path(path)
    parent = next((p for p in path.absolute().parents if p.exists()), None)
    if parent is None or not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise UsageError(f"{option} {path}: cannot create it ({parent} is not a writable directory)")
    return path
