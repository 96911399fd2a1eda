"""The ``platypose`` command line (installed as ``platypose.cli``)."""
