"""The paper's plain scheme: the usual mass matrix, contact forces at t_{n+1} inside the
HHT-alpha recursion like any other force. Kept so that the paper's runs and the comparison of
schemes stay reproducible; with the usual mass it chatters and gains energy at impacts
(docs/contact.md)."""

from __future__ import annotations

from ..scheme import ContactScheme, register_scheme


@register_scheme
class PlainScheme(ContactScheme):
    name = "plain"
