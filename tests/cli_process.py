"""frictionrt as a child process for the Ctrl-C and kill tests."""
import subprocess
import sys
import time

# a shell starts background jobs with SIGINT ignored and children inherit that; Python then
# installs no KeyboardInterrupt handler and the test's Ctrl-C would do nothing (it happened in a
# backgrounded `make test`): the child installs Python's handler itself, then runs the CLI
_CLI_WITH_CTRL_C = ("import runpy, signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
                    "runpy.run_module('frictionrt.rt.cli', run_name='__main__')")


def start_cli(*args) -> subprocess.Popen:
    """``python -m frictionrt.rt.cli ARGS`` with Ctrl-C delivered as in a terminal; text pipes."""
    return subprocess.Popen([sys.executable, "-c", _CLI_WITH_CTRL_C, *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def wait_for_chunks(proc, part, chunks: int) -> None:
    """Until the .part file holds more than `chunks` chunks (~0.6 MB compressed + 0.12 MB of
    message indexes each): the loop is running, whatever the start-up took."""
    t_end = time.monotonic() + 120  # start-up includes a kernel compile if the cache is cold
    while not (part.exists() and part.stat().st_size > chunks * 750_000):
        assert proc.poll() is None, proc.communicate()[1]
        assert time.monotonic() < t_end, "the run never wrote its first chunks"
        time.sleep(0.02)
