"""The explorer's service layer (no viser / fastapi imports): request cost, session store, jobs.

Routers, the GUI and the CLI call these; they hold the rules, the callers only translate.
"""
