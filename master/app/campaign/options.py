"""The value types of a campaign's options, declared once: `tiltload campaign`'s parser takes them as its options'
types, tiltload.CampaignOptions checks its fields by them (case/fields.py)."""

from __future__ import annotations

from ...command_line.argument_types import DAY, integer, time_span
from ..case.fields import Fields, whole_number

HOUR = 3600.0  # s: the longest --connect-timeout (a scheduler that has not answered in an hour will not)

CAMPAIGN = Fields("campaign", {"workers": whole_number, "connect_timeout": time_span(HOUR), "worker_timeout": time_span(DAY),
                               "retries": integer(0, 100)})
