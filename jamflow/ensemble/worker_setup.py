"""Dask worker preload of the local cluster: the worker ignores SIGINT.

A terminal's Ctrl-C reaches the whole process group; the client alone decides what it does
(``jamflow.ensemble.runner``). Workers started with the cluster inherit an ignored SIGINT
from the client; this preload covers workers that a nanny restarts after a kill, from the
moment the worker starts (a Ctrl-C during its first ~second of imports can still print a
traceback from that worker; the run itself stops cleanly)."""

import signal
import threading


def dask_setup(worker):
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
