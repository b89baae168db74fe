"""Fits and diagnoses as bounded, cancellable jobs run in killable worker processes."""
