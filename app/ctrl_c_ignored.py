"""Imported first by the fork server that starts worker processes (see
:mod:`seedtrack.parallel`): from here on it, and every worker it forks, ignores Ctrl-C, which the
command's own process handles by stopping them. Nothing else imports it."""

import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)
