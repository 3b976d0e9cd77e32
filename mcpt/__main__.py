"""``python -m mcpt`` runs the command line."""

from mcpt.cli.main import main

if __name__ == "__main__":
    main(prog_name="mcpt")
