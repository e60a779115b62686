"""The command line, a thin front end over the public API: arguments and exit codes
(:mod:`.command_line`), one case run with its result folder (:mod:`.run`), Ctrl-C and mpirun's SIGTERM
(:mod:`.interrupt`)."""
