"""The durable session store in SQLite: its parts, the integrity check, the salvage of a damaged
file and the clients' shares.
"""
