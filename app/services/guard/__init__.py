"""Who asks and how much: client addresses, allowed hosts, rate limits, known codes, redacted logs
and the strict request-document reader.
"""
