"""Persons of a take: matched across views, the ``--persons`` choice, the views' agreement, a take's keypoints on one
clock."""
