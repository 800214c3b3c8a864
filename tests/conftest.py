"""What every test module shares: the environment the command's output is read in, and a Ctrl-C that
reaches the commands the tests start."""

import os
import signal
import threading
import warnings

import pytest

# pytest-xdist's workers inherit COLUMNS=80 and LINES=24 from their launcher; the tests read the
# command's output as a user piping it would (no COLUMNS: the command's own width for a pipe)
os.environ.pop("COLUMNS", None)
os.environ.pop("LINES", None)


def _restore_ctrl_c(where: str) -> None:
    """Take SIGINT back to Python's own handler, unblocked, warning with ``where`` when it was not: a
    command a test starts inherits an ignored or blocked SIGINT and then never stops on Ctrl-C."""
    if threading.current_thread() is not threading.main_thread():
        return
    handler = signal.getsignal(signal.SIGINT)
    blocked = signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, [])
    if handler is signal.default_int_handler and not blocked:
        return
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    state = "blocked" if blocked else f"handled by {handler!r}"
    warnings.warn(f"SIGINT was {state} {where}; restored", RuntimeWarning, stacklevel=2)


@pytest.fixture(autouse=True)
def _ctrl_c_reaches_commands(request):
    # one test leaving Ctrl-C ignored broke the Ctrl-C tests that a worker ran after it
    _restore_ctrl_c(f"before {request.node.nodeid}")
    yield
    _restore_ctrl_c(f"after {request.node.nodeid}")
