"""The class: lessons a teacher leads and the live pushes to every page."""
