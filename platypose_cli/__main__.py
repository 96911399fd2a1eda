"""``python -m platypose_cli`` runs the ``platypose`` command."""

from platypose_cli.app import main

main()
