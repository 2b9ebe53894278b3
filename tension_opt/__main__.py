"""``python -m tension_opt``: the command line (:mod:`tension_opt.cli`)."""

from tension_opt.cli import main

raise SystemExit(main())
