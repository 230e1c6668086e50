"""The one exception type of the package: the gRPC code, the field path and the message."""
from __future__ import annotations

import grpc

from google.rpc import error_details_pb2, status_pb2

_DETAILS_KEY = "grpc-status-details-bin"


class MdrError(Exception):
    """A failed call.

    code: a grpc.StatusCode; field: the dotted path of the offending request field
    ("steps[3].normal_force"), empty when the error concerns no single field; message: the
    server's explanation without the field prefix. Session.stream also sets `item` (the index
    of the failed item) and `applied_after` (items after it that the server applied).
    """

    item = None
    applied_after = 0

    def __init__(self, code: grpc.StatusCode, field: str, message: str):
        self.code = code
        self.field = field
        self.message = message
        text = f"{field}: {message}" if field else message
        super().__init__(f"{code.name}: {text}")


def _code_of(number: int) -> grpc.StatusCode:
    for code in grpc.StatusCode:
        if code.value[0] == number:
            return code
    return grpc.StatusCode.UNKNOWN


def _field_of(status: status_pb2.Status) -> str:
    """The field from the status's details (BadRequest, or ErrorInfo's metadata "field")."""
    field = ""
    for detail in status.details:
        bad_request, info = error_details_pb2.BadRequest(), error_details_pb2.ErrorInfo()
        if detail.Unpack(bad_request) and bad_request.field_violations:
            return bad_request.field_violations[0].field
        if detail.Unpack(info):
            field = info.metadata.get("field", field)
    return field


def _split(field: str, text: str) -> str:
    """The message without the "field: " prefix the server puts in front of it."""
    prefix = f"{field}: "
    return text[len(prefix):] if field and text.startswith(prefix) else text


def from_status(status: status_pb2.Status) -> MdrError:
    """The error a google.rpc.Status describes (StreamApply's per-message status)."""
    field = _field_of(status)
    return MdrError(_code_of(status.code), field, _split(field, status.message))


def from_rpc_error(error: grpc.RpcError) -> MdrError:
    """The error of a failed call, with the field from its binary error details."""
    code = error.code() if hasattr(error, "code") else grpc.StatusCode.UNKNOWN
    text = error.details() if hasattr(error, "details") else str(error)
    status = status_pb2.Status(code=code.value[0], message=text or "")
    for key, value in (error.trailing_metadata() or ()) if hasattr(error, "trailing_metadata") else ():
        if key == _DETAILS_KEY:
            status.ParseFromString(value)
    field = _field_of(status)
    return MdrError(code, field, _split(field, text or ""))
