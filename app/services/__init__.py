"""The explorer's service layer (no viser / fastapi imports).

- :mod:`.config`: the immutable :class:`~.config.Config` (model, signal, mismatch).
- :mod:`.store`: the one typed session state :class:`~.store.SessionState` and its
  SQLite store.
- :mod:`.sessions`: live sessions (a state replaced as a whole on each transition,
  listeners, locks) and the registry by code.
- :mod:`.actions`: the transitions and reads the routers and the viser GUI call (load a
  preset, change the config, load a parameter set, upload, fit,
  diagnose, export, the teacher's push, figures of the views asked for).
- :mod:`.cost` (request cost, checked before work), :mod:`.jobs` (fit and diagnosis
  jobs), :mod:`.ratelimit` (per-client buckets), :mod:`.columns` (CSV column options).

Routers, the GUI and the CLI call these; they hold the rules, the callers only translate.
"""
