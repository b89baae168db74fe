"""The file-based runs' inputs and progress lines (``hyst`` commands and ``hyst batch``)."""
