"""``python -m platypose`` runs the ``platypose`` command."""

from platypose.cli.app import main

main()
