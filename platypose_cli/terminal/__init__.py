"""What the user types and reads: the options built from the library's settings classes (``options``), the brief
``--help`` (``brief_help``), the lines printed around a batch (``console``), progress bars (``progress_bars``), and
names made safe for files and console lines (``safe_names``)."""
