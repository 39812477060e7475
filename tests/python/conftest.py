"""Shared by the Python tests: Ctrl-C behaves the same however the suite is launched.

A shell that starts a job in the background without job control (`cmd &` in a script, nohup)
starts it with SIGINT ignored; Python then installs no KeyboardInterrupt handler, in this process
or in the processes it starts, and the Ctrl-C tests would see no interrupt at all. Python's own
handler is restored here; a process started from this one then begins with SIGINT at its default
(an ignored signal stays ignored across exec, a handler does not), as from a terminal."""

import signal

signal.signal(signal.SIGINT, signal.default_int_handler)
