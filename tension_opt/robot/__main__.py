"""``python -m tension_opt.robot check FILE``: see :mod:`tension_opt.robot_cli`."""

import sys

from tension_opt.robot_cli import main

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
