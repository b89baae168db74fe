"""A live session and what the interfaces do to it: the transitions, the actions and the
downloads."""
