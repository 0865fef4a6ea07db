"""Evaluation protocol, reference scores and videos."""
