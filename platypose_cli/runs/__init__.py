"""The runner of ``platypose lift`` (and ``demo``): INPUT paths -> jobs -> one output folder each, by job.

- ``jobs``: INPUT paths, folders and globs -> jobs (one take of one or more views each); ``folders``: each job's
  own ``OUT/<name>/``.
- ``settings``: what a job needs besides its views; ``models``: the detector and prior loaded once per process, the
  view reader on them.
- ``job``: one job run: views -> :func:`platypose.pipeline.run_take` -> files; ``outputs``: staging, export and
  the set of files; ``records`` and ``fingerprint``: what ``--resume`` reads (lift.json, failed.json, summary.json)
  and compares; ``locks``: one writer per folder.
- ``batch``: a batch of jobs (resume, processes, summary.json); ``workers``: threads and signals of the processes.
- Executors, each handing the job its hooks: ``ray`` (``--executor ray``, ``ray_address``), ``split``
  (``--split-seconds``: the driver, plans and joins pieces), ``pieces`` (the piece tasks), ``pools`` (the processes
  or Ray tasks that run them), ``piece_plan`` and ``piece_files`` (a piece trusted and read back).
- ``bench_clip``: ``bench``'s timed detection and lift of one clip.
"""
