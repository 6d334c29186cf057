"""What the tests that start a child Python process share."""

SIGINT_PRELUDE = "import signal\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"
"""The first lines of a child that a test interrupts with SIGINT. A shell that starts a job
in the background (``cmd &`` without job control) makes it ignore SIGINT, Python then installs
no handler of its own, and the child would never see the signal: it restores Python's."""
