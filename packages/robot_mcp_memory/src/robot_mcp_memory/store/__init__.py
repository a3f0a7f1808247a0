"""Process store port and its adapters."""

from robot_mcp_memory.store.base import (
    Candidate,
    OutcomeRecord,
    OutcomeStats,
    ProcessNotFoundError,
    ProcessStore,
    ProcessSummary,
    SaveResult,
    SearchQuery,
    StoredProcess,
    StoreError,
)

__all__ = [
    "Candidate",
    "OutcomeRecord",
    "OutcomeStats",
    "ProcessNotFoundError",
    "ProcessStore",
    "ProcessSummary",
    "SaveResult",
    "SearchQuery",
    "StoreError",
    "StoredProcess",
]
