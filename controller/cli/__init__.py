"""The ``imotion`` command line: every operation of the daemon, ``watch`` and ``list``."""
