"""raycastd: a client for the raycastd ray-query service, its command line and a grading kit.

    from raycastd import Client
    with Client() as c:                       # $RAYCASTD_URL, else http://127.0.0.1:8080
        c.intersect(scene_doc, [((0, 0, 0), (0, 0, 1))])["hits"][0]["name"]

Standard library only; NumPy is used by the array queries when it is installed.
"""

from raycastd.arrays import MISS_ID
from raycastd.client import DEFAULT_URL, Client
from raycastd.errors import (
    BadRequest,
    Busy,
    ClientError,
    ClientTimeout,
    ConnectionFailed,
    InsufficientStorage,
    InternalError,
    MethodNotAllowed,
    ModelLoadFailed,
    NotFound,
    RaycastdError,
    ServerError,
    TooLarge,
    Unauthorized,
)

__version__ = "0.2.0"

__all__ = [
    "BadRequest",
    "Busy",
    "Client",
    "ClientError",
    "ClientTimeout",
    "ConnectionFailed",
    "DEFAULT_URL",
    "InsufficientStorage",
    "InternalError",
    "MISS_ID",
    "MethodNotAllowed",
    "ModelLoadFailed",
    "NotFound",
    "RaycastdError",
    "ServerError",
    "TooLarge",
    "Unauthorized",
]
