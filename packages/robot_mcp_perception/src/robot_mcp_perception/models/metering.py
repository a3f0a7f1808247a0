"""Per-request metering of cloud model calls (spec 000 §8: meter every cloud call).

The node meters *requests*, not skill runs: a segment_all run sends one pointing request per
tile plus a grounding request, and an adapter's retry is another request. The engine puts a
:class:`RequestMeter` (the run's budget reservation) in a context variable around each run;
every cloud request is charged to it right before it is sent:

- the pipelines charge one request per call of a cloud grounder / segmenter
  (``pipelines.common.call_grounder`` / ``call_segmenter``);
- an adapter that retries charges each retry itself (``GeminiERGrounder``).

A meter that refuses a charge (the budget is spent) makes the request fail with
:class:`CloudBudgetExhaustedError` before anything is sent. Without a meter (an adapter used
on its own) charging is a no-op.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Protocol

from robot_mcp_perception.models.base import ModelError


class CloudBudgetExhaustedError(ModelError):
    """A cloud request was not sent: the node's cloud budget has no room for it."""


class RequestMeter(Protocol):
    def charge(self) -> bool:
        """Count one cloud request about to be sent; False refuses it."""
        ...


_current: ContextVar[RequestMeter | None] = ContextVar("cloud_request_meter", default=None)


@contextmanager
def metered(meter: RequestMeter | None) -> Iterator[None]:
    """Charge the cloud requests made inside this block (and tasks it starts) to ``meter``."""
    token = _current.set(meter)
    try:
        yield
    finally:
        _current.reset(token)


def charge_cloud_request(what: str) -> None:
    """Charge one request to the current meter; raises when the meter refuses it."""
    meter = _current.get()
    if meter is not None and not meter.charge():
        raise CloudBudgetExhaustedError(
            f"{what} not sent: the cloud budget (cost.max_cloud_calls_per_min) is spent",
            "budget",
        )
