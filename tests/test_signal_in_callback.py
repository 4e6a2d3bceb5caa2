"""A signal whose exception lands in a weak reference's callback still stops the command, with no traceback."""

import subprocess
import sys
import textwrap

PROGRAM = textwrap.dedent("""
    import os, signal, sys, time, weakref
    from rollsim.errors import Interrupted
    from rollsim.plumbing import signals

    class Thing:
        pass

    def callback(_ref):
        # The signal arrives while the garbage collector runs this callback: Python cannot raise here.
        os.kill(os.getpid(), signal.SIGTERM)
        deadline = time.monotonic() + 0.5
        while time.monotonic() < deadline:
            pass

    saved = signals.install_handlers()
    try:
        thing = Thing()
        ref = weakref.ref(thing, callback)
        del thing
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            time.sleep(0.01)
        print("not stopped")
        sys.exit(0)
    except Interrupted as exc:
        print(f"stopped by {exc.signum}")
        sys.exit(128 + exc.signum)
    finally:
        signals.restore_handlers(saved)
""")


def test_a_signal_dropped_in_a_callback_is_delivered_again_outside_it():
    done = subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True, timeout=60)
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr, done.stderr
    assert done.stdout.strip() == "stopped by 15" and done.returncode == 128 + 15


def test_the_hook_is_restored_with_the_handlers():
    from rollsim.plumbing import signals

    before = sys.unraisablehook
    saved = signals.install_handlers()
    assert sys.unraisablehook is not before
    signals.restore_handlers(saved)
    assert sys.unraisablehook is before
