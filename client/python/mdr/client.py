"""The client: one method per RPC, a deadline on every call, retries of idempotent calls on
UNAVAILABLE, errors raised as MdrError. Sessions are handles and context managers."""
from __future__ import annotations

import random
import threading
import time
from typing import Iterable, Optional, Sequence, Union

import grpc

from mdr.v1 import contact_service_pb2 as api
from mdr.v1 import contact_service_pb2_grpc as api_grpc

from . import analysis
from .embedded import EmbeddedServer
from .errors import MdrError, from_rpc_error, from_status
from .messages import ApplyResult, QueryResult, SceneLike, StepLike, to_scene, to_steps

_ROUTES = {"both": api.TRACTION_ROUTE_BOTH, "abel": api.TRACTION_ROUTE_ABEL,
                   "jager": api.TRACTION_ROUTE_JAGER}
# Metadata key carrying the id of the session a call names, so that a router pins every call on a
# session, its creation included, to one server (consistent hashing; deploy/haproxy).
SESSION_ROUTING_KEY = "x-session-id"


def new_session_id() -> str:
    """A fresh id of the API's form [a-z][a-z0-9-]{0,62}: the client chooses the ids of the
    sessions it creates or imports, so that a router can route the creation."""
    return f"c{random.SystemRandom().getrandbits(64):016x}"


def _routing(session: str) -> tuple:
    """The routing metadata of a call naming `session` ("sessions/{id}" or a bare id)."""
    if not session:
        return ()
    return ((SESSION_ROUTING_KEY, session.removeprefix("sessions/")),)


def _read(path: Optional[str]) -> Optional[bytes]:
    if path is None:
        return None
    with open(path, "rb") as stream:
        return stream.read()


def _mask(paths: Optional[Sequence[str]]):
    from google.protobuf import field_mask_pb2
    return field_mask_pb2.FieldMask(paths=list(paths or ()))


class Client(analysis.AnalysisCalls):
    """A connection to mdrd.

    address: "host:port". tls: False (plaintext), True (TLS with the system's roots), or a dict
    with any of root_certificates, certificate_chain, private_key (PEM file paths; the last two
    for mutual TLS). token: a bearer token (mdrd --tokens-file). timeout: seconds, the deadline
    of every call (of a whole stream). max_attempts / initial_backoff: retries of idempotent
    calls (GetSession, ListSessions, ExportSession, Query, Transform, Apply with a request_id,
    the stateless analysis calls; FitLoops only before its first message) that fail with
    UNAVAILABLE, the wait doubling each time.
    """

    def __init__(self, address: str, *, tls: Union[bool, dict] = False,
                 token: Optional[str] = None, timeout: float = 30.0, max_attempts: int = 3,
                 initial_backoff: float = 0.1, _server: Optional[EmbeddedServer] = None):
        if max_attempts < 1:
            raise ValueError(f"max_attempts must be >= 1, got {max_attempts}")
        if not timeout > 0:
            raise ValueError(f"timeout must be > 0 seconds, got {timeout}")
        # Messages of any size both ways, as the C++ client: the server's --max-message-bytes
        # bounds them (gRPC's client default, 4 MiB received, would refuse what it sends).
        options = [("grpc.max_receive_message_length", -1),
                   ("grpc.max_send_message_length", -1)]
        if tls:
            files = tls if isinstance(tls, dict) else {}
            credentials = grpc.ssl_channel_credentials(
                root_certificates=_read(files.get("root_certificates")),
                private_key=_read(files.get("private_key")),
                certificate_chain=_read(files.get("certificate_chain")))
            self._channel = grpc.secure_channel(address, credentials, options)
        else:
            self._channel = grpc.insecure_channel(address, options)
        self._stub = api_grpc.ContactServiceStub(self._channel)
        self._metadata = (("authorization", f"Bearer {token}"),) if token else ()
        self.address = address
        self.timeout = timeout
        self.max_attempts = max_attempts
        self.initial_backoff = initial_backoff
        self._server = _server

    @classmethod
    def embedded(cls, mdrd: Optional[str] = None, args: Sequence[str] = (), *,
                 in_process: bool = False, library: Optional[str] = None, **options):
        """Starts a local mdrd (see EmbeddedServer) and connects to it; close() stops it.
        in_process=True: no server at all, the sessions run in this process through libmdr_c
        (mdr.inprocess.InProcessClient: the same session API, one contact per session; library:
        the library's path, default $MDR_C_LIBRARY or the system's libmdr_c.so.1)."""
        if in_process:
            from .inprocess import InProcessClient  # ctypes only: no server, no gRPC call
            return InProcessClient(library)
        server = EmbeddedServer(mdrd, args)
        try:
            return cls(server.address, _server=server, **options)
        except BaseException:
            server.stop()
            raise

    def close(self) -> None:
        self._channel.close()
        if self._server is not None:
            self._server.stop()
            self._server = None

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # The calls.
    def _call(self, method: str, request, idempotent: bool, session: str = ""):
        rpc = getattr(self._stub, method)
        metadata = self._metadata + _routing(session)
        backoff = self.initial_backoff
        for attempt in range(1, self.max_attempts + 1):
            try:
                return rpc(request, timeout=self.timeout, metadata=metadata)
            except grpc.RpcError as error:
                retry = (idempotent and attempt < self.max_attempts
                         and error.code() == grpc.StatusCode.UNAVAILABLE)
                if not retry:
                    raise from_rpc_error(error) from None
            time.sleep(backoff)
            backoff *= 2
        raise AssertionError("unreachable")

    def _call_stream(self, method: str, request, on_message, timeout: Optional[float] = None):
        """Reads a server stream, handing every message to on_message; retried on UNAVAILABLE
        (the calls are stateless) only while no message has arrived. on_message's exceptions
        cancel the call and propagate."""
        rpc = getattr(self._stub, method)
        backoff = self.initial_backoff
        for attempt in range(1, self.max_attempts + 1):
            call = rpc(request, timeout=timeout or self.timeout, metadata=self._metadata)
            received = False
            try:
                for message in call:
                    received = True
                    on_message(message)
                return
            except grpc.RpcError as error:
                retry = (not received and attempt < self.max_attempts
                         and error.code() == grpc.StatusCode.UNAVAILABLE)
                if not retry:
                    raise from_rpc_error(error) from None
            finally:
                call.cancel()
            time.sleep(backoff)
            backoff *= 2
        raise AssertionError("unreachable")

    def create_session(self, scene: SceneLike, session_id: str = "",
                       limits: Optional[api.SessionLimits] = None) -> "Session":
        """A new unloaded session for the scene (a Scene, a dict or a scene file path); an empty
        session_id: the client picks one."""
        request = api.CreateSessionRequest(session_id=session_id or new_session_id())
        request.session.scene.CopyFrom(to_scene(scene))
        if limits is not None:
            request.session.limits.CopyFrom(limits)
        return Session(self, self._call("CreateSession", request, idempotent=False,
                                        session=request.session_id).name)

    def session(self, scene: SceneLike, session_id: str = "",
                limits: Optional[api.SessionLimits] = None) -> "Session":
        """As create_session; used as a context manager, the session is deleted on exit."""
        return self.create_session(scene, session_id, limits)

    def get_session(self, name: str) -> api.Session:
        return self._call("GetSession", api.GetSessionRequest(name=name), idempotent=True,
                          session=name)

    def list_sessions(self) -> list:
        """Every session (following the pages), as mdr.v1.Session resources."""
        sessions, token = [], ""
        while True:
            page = self._call("ListSessions", api.ListSessionsRequest(page_token=token),
                              idempotent=True)
            sessions.extend(page.sessions)
            token = page.next_page_token
            if not token:
                return sessions

    def delete_session(self, name: str) -> None:
        self._call("DeleteSession", api.DeleteSessionRequest(name=name), idempotent=False,
                   session=name)

    def export_session(self, name: str) -> api.SessionSnapshot:
        return self._call("ExportSession", api.ExportSessionRequest(name=name), idempotent=True,
                          session=name)

    def import_session(self, snapshot: api.SessionSnapshot, session_id: str = "") -> "Session":
        request = api.ImportSessionRequest(session_id=session_id or new_session_id())
        request.snapshot.CopyFrom(snapshot)
        return Session(self, self._call("ImportSession", request, idempotent=False,
                                        session=request.session_id).name)

    def transform(self, scene: SceneLike, *, superposition=None, samples=None,
                  radii: Sequence[float] = (), route: str = "both") -> api.TransformResponse:
        """Stateless: Cattaneo-Mindlin superposition <-> memory, or sampled u(x) -> weights.
        superposition: a CattaneoMindlinSuperposition (or dict); samples: a
        SampledDisplacement (or dict with x and u)."""
        from google.protobuf import json_format
        request = api.TransformRequest(scene=to_scene(scene), radii=list(radii),
                                       traction_route=_route(route))
        if (superposition is None) == (samples is None):
            raise ValueError("transform needs exactly one of superposition and samples")
        if superposition is not None:
            target = request.superposition
            source = superposition
        else:
            target = request.samples
            source = samples
        if isinstance(source, dict):
            json_format.ParseDict(source, target)
        else:
            target.CopyFrom(source)
        return self._call("Transform", request, idempotent=True)

    # The analysis (AnalysisCalls): unary calls, and FitLoops' stream of progress and result.
    def _analyze(self, method: str, request):
        return self._call(method, request, idempotent=True)

    def _fit(self, request, on_progress, timeout: Optional[float]):
        results = []

        def on_message(message):
            if message.HasField("progress"):
                on_progress(message.progress)
            elif message.HasField("result"):
                results.append(message.result)

        self._call_stream("FitLoops", request, on_message, timeout)
        if not results:
            raise MdrError(grpc.StatusCode.UNKNOWN, "",
                           "the FitLoops stream ended without a result")
        return results[-1]

def _route(route: str) -> int:
    if route not in _ROUTES:
        raise ValueError(f"route must be one of {sorted(_ROUTES)}, got {route!r}")
    return _ROUTES[route]


class Session:
    """A session on the server ("sessions/{id}"). As a context manager it is deleted on exit."""

    def __init__(self, client: Client, name: str):
        self.client = client
        self.name = name

    def __enter__(self) -> "Session":
        return self

    def __exit__(self, *exc) -> None:
        try:
            self.delete()
        except MdrError as error:
            if error.code != grpc.StatusCode.NOT_FOUND:
                raise

    def __repr__(self) -> str:
        return f"Session({self.name!r})"

    def get(self) -> api.Session:
        return self.client.get_session(self.name)

    def delete(self) -> None:
        self.client.delete_session(self.name)

    def export(self) -> api.SessionSnapshot:
        return self.client.export_session(self.name)

    def _request(self, steps, outputs, request_id: str,
                 state_fields: Sequence[str] = ()) -> api.ApplyRequest:
        request = api.ApplyRequest(session=self.name, steps=to_steps(steps),
                                   request_id=request_id)
        request.step_mask.CopyFrom(_mask(outputs))
        request.state_mask.CopyFrom(_mask(state_fields))
        return request

    def apply(self, steps: Union[StepLike, Iterable[StepLike]],
              outputs: Sequence[str] = ("state",), request_id: str = "",
              state_fields: Sequence[str] = ()) -> ApplyResult:
        """Applies the steps as one atomic batch (all or none). outputs: the per-step results
        (step_mask paths: "state", "substeps", "path_error", "dissipated_energy"; () for none).
        state_fields: the ContactState fields of the final state to compute and send, e.g.
        ("tangential_force",) (state_mask; () for all). With a request_id the call is
        idempotent and retried on UNAVAILABLE."""
        response = self.client._call("Apply",
                                     self._request(steps, outputs, request_id, state_fields),
                                     idempotent=bool(request_id), session=self.name)
        return ApplyResult.of(response)

    def stream(self, steps: Iterable[Union[StepLike, Sequence[StepLike]]],
               outputs: Sequence[str] = ("state",), window: int = 32,
               timeout: Optional[float] = None,
               state_fields: Sequence[str] = ()) -> Iterable[ApplyResult]:
        """Streams the steps (each item a step, or a list of steps for one atomic batch) and
        yields one ApplyResult per item, in order. At most `window` items are in flight: the
        iterable is read only as results are consumed (back-pressure). The server applies every
        item on its own; at the first item that fails, nothing more is sent, the answers to the
        items already in flight are read, and MdrError is raised with `item` (the failed item's
        index) and `applied_after` (how many of the in-flight items after it were applied, at
        most window - 1). timeout: the deadline of the whole stream in seconds (default: the
        client's). state_fields: as in apply, for every item."""
        if window < 1:
            raise ValueError(f"window must be >= 1, got {window}")
        credit = threading.Semaphore(window)
        stop = threading.Event()

        def requests():
            for item in steps:
                while not credit.acquire(timeout=0.1):
                    if stop.is_set():
                        return
                if stop.is_set():
                    return
                yield api.StreamApplyRequest(
                    apply=self._request(item, outputs, "", state_fields))

        call = self.client._stub.StreamApply(
            requests(), timeout=timeout or self.client.timeout,
            metadata=self.client._metadata + _routing(self.name))
        failure, index = None, 0
        try:
            for answer in call:
                credit.release()
                if failure is not None:
                    failure.applied_after += answer.status.code == 0
                elif answer.status.code != 0:
                    stop.set()
                    failure = from_status(answer.status)
                    failure.item, failure.applied_after = index, 0
                else:
                    yield ApplyResult.of(answer.result)
                index += 1
        except grpc.RpcError as error:
            if failure is None:
                raise from_rpc_error(error) from None
        finally:
            stop.set()
            call.cancel()
        if failure is not None:
            raise failure

    def query(self, outputs: Sequence[str] = ("state",), radii: Sequence[float] = (),
              route: str = "both", contact_index: Optional[int] = None,
              slip_histogram_bins: int = 0) -> QueryResult:
        """The selected outputs (read_mask paths, e.g. "state", "tractions", "pressure",
        "springs", "jager_weights", "slip_intervals", "energy"); radii for the radial ones.
        An interface session also takes "interface.totals", "interface.slip_histogram" (with
        slip_histogram_bins, 1 to 1000) and "interface.memory_bytes" (QueryResult.interface);
        its "state" is the interface's, or with contact_index (in [0, N)) that contact's, which
        the other paths need. The server checks both and names them in its MdrError."""
        if contact_index is not None and contact_index < 0:
            raise ValueError(f"contact_index must be >= 0 (a contact in [0, N)), got "
                             f"{contact_index}")
        if not -2**31 <= slip_histogram_bins < 2**31:
            raise ValueError(f"slip_histogram_bins must fit the request's int32 (the service "
                             f"takes 1 to 1000), got {slip_histogram_bins}")
        request = api.QueryRequest(session=self.name, radii=list(radii),
                                   traction_route=_route(route), contact_index=contact_index,
                                   slip_histogram_bins=slip_histogram_bins)
        request.read_mask.CopyFrom(_mask(outputs))
        return QueryResult.of(self.client._call("Query", request, idempotent=True,
                                                session=self.name))
