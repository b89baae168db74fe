"""The lessons shipped with the explorer: one JSON lesson file per lesson (package data).

Read them with :func:`app.services.teaching.lessons.builtin_lessons`; the file name without
``.json`` is the lesson's name, after the number that orders the lessons (``1-pi-basics.json`` is
``pi-basics``, shown first). The numbers in the texts are paper 001's and paper 000's
printed examples (see the presets, :mod:`core.presets`).
"""
