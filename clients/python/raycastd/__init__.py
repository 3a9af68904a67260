"""A small client for the raycastd HTTP API (standard library only)."""

from raycastd.client import Client, RaycastdError

__all__ = ["Client", "RaycastdError"]
