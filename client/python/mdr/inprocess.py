"""Sessions in this process, through libmdr_c (the engine's C interface, docs/capi.md), with no
server: the same session API as Client and Session, for a notebook or a rig script that switches
by one argument:

    with mdr.Client.embedded(in_process=True) as client:   # mdr.Client.embedded(): a local mdrd
        with client.session("examples/hertz_cattaneo_mindlin.json") as s:
            s.apply({"normal_force": 100})
            r = s.apply([{"tangential_force": f} for f in (5, 10, 15)])
            r.tangential_displacement                      # numpy array, one value per step

The numbers are the service's, bit for bit (the library runs the service's conversion and the
same engine), and snapshots move both ways (export() / import_session()). One contact per session,
tangential or torsional (scene.torsion: steps by twist, twist_increment or twisting_moment, the
"torsion.*" query outputs): interface scenes need a server. The analysis (analyze_loops,
fit_loops, fretting_map, backbone) runs the service's own operations through mdr_analysis_run.
The library is found at $MDR_C_LIBRARY, next to this package, or by the system's loader
(libmdr_c.so.1).
"""
import ctypes
import ctypes.util
import itertools
import os
import time
from typing import Iterable, Optional, Sequence, Union

import grpc

from . import analysis
from .errors import MdrError
from .messages import ApplyResult, QueryResult, SceneLike, StepLike, to_scene, to_steps
from .v1 import analysis_pb2 as an
from .v1 import contact_service_pb2 as api

_OUT_OF_RANGE = 11
# mdr_progress_callback: int (*)(const void* progress, size_t size, void* user)
_PROGRESS = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p)
_NORMAL = {"depth": 1, "depth_increment": 2, "normal_force": 3}
_TANGENTIAL = {"displacement": 1, "displacement_increment": 2, "tangential_force": 3}
_TWIST = {"twist": 1, "twist_increment": 2, "twisting_moment": 3}
_ROUTES = {"both": 1, "abel": 2, "jager": 3}
# The ContactState fields that mdr_state carries, in its order (mdr.h).
_STATE_DOUBLES = ("depth", "tangential_displacement", "contact_radius", "normal_force",
                  "tangential_force", "dissipated_energy", "friction_limit",
                  "actuator_displacement", "actuator_depth", "last_step_dissipation")
_QUERY_OUTPUTS = ("state", "tangential_stiffness", "slip_intervals", "jager_weights",
                  "tractions", "pressure")
# mdr_torsional_state's doubles, in its order (mdr.h); the ContactState fields of the same names.
_TORSIONAL_STATE_DOUBLES = ("depth", "contact_radius", "normal_force", "twist", "twisting_moment",
                            "full_slip_moment", "dissipated_energy", "last_step_dissipation",
                            "friction_limit")
_TORSION_OUTPUTS = ("stiffness", "slip_intervals", "tractions", "memory_pieces", "stored_energy")
# The service's refusal of a tangential channel in a torsional session (torsion_session.cc).
_TANGENTIAL_IN_TORSION = (
    "must be unset in a torsional session (scene.torsion): a twist combined with a tangential "
    "displacement or force has no exact model (docs/physics.md, \"Torsion\"); drive such a "
    "contact tangentially in a session without scene.torsion")
_STEP_OUTPUTS = ("state", "substeps", "path_error", "dissipated_energy")


class _State(ctypes.Structure):
    _fields_ = [(name, ctypes.c_double) for name in _STATE_DOUBLES] + [
        ("applied_steps", ctypes.c_uint64), ("memory_vertices", ctypes.c_uint64)]


class _TorsionalState(ctypes.Structure):
    _fields_ = [(name, ctypes.c_double) for name in _TORSIONAL_STATE_DOUBLES] + [
        ("applied_steps", ctypes.c_uint64), ("memory_pieces", ctypes.c_uint64)]


class _StepReport(ctypes.Structure):
    _fields_ = [("substeps", ctypes.c_int32), ("reserved", ctypes.c_int32),
                ("path_error", ctypes.c_double), ("dissipated", ctypes.c_double)]


def _library_path() -> str:
    if os.environ.get("MDR_C_LIBRARY"):
        return os.environ["MDR_C_LIBRARY"]
    beside = os.path.join(os.path.dirname(__file__), "libmdr_c.so.1")
    if os.path.exists(beside):
        return beside
    return ctypes.util.find_library("mdr_c") or "libmdr_c.so.1"


def load_library(path: Optional[str] = None) -> ctypes.CDLL:
    """libmdr_c with the signatures of mdr.h (interface version 1, revision 3 or later)."""
    where = path or _library_path()
    try:
        lib = ctypes.CDLL(where)
    except OSError as error:
        raise ImportError(
            f"libmdr_c could not be loaded ({error}). Install the package from the repository "
            f"(pip install client/python builds and bundles libmdr_c.so.1), or set "
            f"MDR_C_LIBRARY to the library's path (built as build/release/capi/libmdr_c.so.1)"
        ) from None
    # Revision 3 brought the torsion functions; a library before it lacks their symbols.
    revision = lib.mdr_api_revision() if hasattr(lib, "mdr_api_revision") else 1
    if revision < 3:
        raise ImportError(f"libmdr_c at {where} is of interface revision {revision}; this "
                          f"package needs revision 3 (torsional contacts): rebuild or reinstall "
                          f"it with the package")
    handle, size, dbl = ctypes.c_void_p, ctypes.c_size_t, ctypes.POINTER(ctypes.c_double)
    signatures = {
        "mdr_version": [],
        "mdr_contact_create": [ctypes.c_char_p, size, ctypes.POINTER(handle)],
        "mdr_contact_restore": [ctypes.c_char_p, size, ctypes.POINTER(handle)],
        "mdr_contact_step": [handle, ctypes.c_int, ctypes.c_double, ctypes.c_int,
                             ctypes.c_double, ctypes.POINTER(_StepReport)],
        "mdr_contact_state": [handle, ctypes.POINTER(_State)],
        "mdr_contact_stiffness": [handle, dbl, dbl],
        "mdr_contact_slip_intervals": [handle, dbl, dbl, ctypes.POINTER(ctypes.c_int32), size,
                                       ctypes.POINTER(size)],
        "mdr_contact_jager_weights": [handle, dbl, dbl, dbl, size, ctypes.POINTER(size), dbl],
        "mdr_contact_tractions": [handle, dbl, size, ctypes.c_int, dbl, dbl, dbl, dbl, size],
        "mdr_contact_snapshot": [handle, ctypes.c_void_p, size, ctypes.POINTER(size)],
        "mdr_last_error_code": [],
        "mdr_torsion_create": [ctypes.c_char_p, size, ctypes.POINTER(handle)],
        "mdr_torsion_restore": [ctypes.c_char_p, size, ctypes.POINTER(handle)],
        "mdr_torsion_step": [handle, ctypes.c_int, ctypes.c_double, ctypes.c_int,
                             ctypes.c_double, ctypes.POINTER(_StepReport)],
        "mdr_torsion_state": [handle, ctypes.POINTER(_TorsionalState)],
        "mdr_torsion_stiffness": [handle, dbl, dbl],
        "mdr_torsion_slip_intervals": [handle, dbl, dbl, ctypes.POINTER(ctypes.c_int32), size,
                                       ctypes.POINTER(size)],
        "mdr_torsion_tractions": [handle, dbl, size, dbl, dbl, size],
        "mdr_torsion_stored_energy": [handle, dbl],
        "mdr_torsion_snapshot": [handle, ctypes.c_void_p, size, ctypes.POINTER(size)],
    }
    signatures["mdr_analysis_run"] = [ctypes.c_int, ctypes.c_int, ctypes.c_char_p, size,
                                      _PROGRESS, ctypes.c_void_p, ctypes.POINTER(handle)]
    if revision >= 4:  # the harmonic-balance element (mdr.dynamics)
        signatures["mdr_element_create"] = [ctypes.c_char_p, size, ctypes.c_double,
                                            ctypes.POINTER(handle)]
        signatures["mdr_element_aft"] = [handle, dbl, size, ctypes.POINTER(ctypes.c_int32), size,
                                         ctypes.c_int32, dbl, dbl, dbl]
    for name, arguments in signatures.items():
        getattr(lib, name).argtypes = arguments
        getattr(lib, name).restype = ctypes.c_int
    lib.mdr_contact_destroy.argtypes, lib.mdr_contact_destroy.restype = [handle], None
    lib.mdr_torsion_destroy.argtypes, lib.mdr_torsion_destroy.restype = [handle], None
    if revision >= 4:
        lib.mdr_element_destroy.argtypes, lib.mdr_element_destroy.restype = [handle], None
    lib.mdr_buffer_data.argtypes, lib.mdr_buffer_data.restype = [handle], ctypes.c_void_p
    lib.mdr_buffer_size.argtypes, lib.mdr_buffer_size.restype = [handle], size
    lib.mdr_buffer_destroy.argtypes, lib.mdr_buffer_destroy.restype = [handle], None
    lib.mdr_last_error_message.restype = ctypes.c_char_p
    lib.mdr_last_error_field.restype = ctypes.c_char_p
    if lib.mdr_version() != 1:
        raise ImportError(f"libmdr_c interface version {lib.mdr_version()}, this package "
                          f"reads version 1")
    return lib


def _code_of(number: int) -> grpc.StatusCode:
    for code in grpc.StatusCode:
        if code.value[0] == number:
            return code
    return grpc.StatusCode.UNKNOWN


def check(lib: ctypes.CDLL, status: int) -> None:
    """Raises the calling thread's last libmdr_c error as an MdrError unless status is 0."""
    if status == 0:
        return
    field = lib.mdr_last_error_field().decode()
    message = lib.mdr_last_error_message().decode()
    raise MdrError(_code_of(status), field, _without_prefix(message, field) if field else message)


class InProcessClient(analysis.AnalysisCalls):
    """Client's session and analysis calls, in this process. As a context manager: nothing to
    stop."""

    def __init__(self, library: Optional[str] = None):
        self._lib = load_library(library)
        self._sessions = {}
        self._ids = itertools.count(1)

    def __enter__(self) -> "InProcessClient":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        for session in list(self._sessions.values()):
            session.delete()

    def _check(self, status: int) -> None:
        check(self._lib, status)

    # The analysis: mdr_analysis_run on the serialized request, the service's own operations.
    _ANALYSES = {"AnalyzeLoops": (1, an.AnalyzeLoopsResponse), "FitLoops": (2, an.FitResult),
                 "FrettingMap": (3, an.FrettingMapResponse), "Backbone": (4, an.BackboneResponse)}

    def _run_analysis(self, method: str, request, callback=None):
        number, response_type = self._ANALYSES[method]
        data = request.SerializeToString()
        response = ctypes.c_void_p()
        status = self._lib.mdr_analysis_run(number, 0, data, len(data),
                                            callback or _PROGRESS(), None,
                                            ctypes.byref(response))
        self._check(status)
        try:
            size = self._lib.mdr_buffer_size(response)
            return response_type.FromString(ctypes.string_at(self._lib.mdr_buffer_data(response),
                                                             size))
        finally:
            self._lib.mdr_buffer_destroy(response)

    def _analyze(self, method: str, request):
        return self._run_analysis(method, request)

    def _fit(self, request, on_progress, timeout: Optional[float]):
        deadline = None if timeout is None else time.monotonic() + timeout
        raised = []

        def progress(message, size, user):
            try:
                on_progress(an.FitProgress.FromString(ctypes.string_at(message, size)))
            except BaseException as error:  # a caller's exception stops the fit, then is raised
                raised.append(error)
                return 1
            return 1 if deadline is not None and time.monotonic() > deadline else 0

        callback = _PROGRESS(progress)
        try:
            return self._run_analysis("FitLoops", request, callback)
        except MdrError as error:
            if raised:
                raise raised[0] from None
            if error.code == grpc.StatusCode.CANCELLED and deadline is not None:
                raise MdrError(grpc.StatusCode.DEADLINE_EXCEEDED, "timeout",
                               f"the fit took longer than {timeout} s") from None
            raise

    def _adopt(self, kind, handle: ctypes.c_void_p, session_id: str) -> "InProcessSession":
        session_id = session_id or f"local-{next(self._ids)}"
        name = f"sessions/{session_id}"
        if name in self._sessions:
            kind.function(self._lib, "destroy")(handle)
            raise MdrError(grpc.StatusCode.ALREADY_EXISTS, "session_id",
                           f"a session {name!r} exists")
        session = kind(self, name, handle)
        self._sessions[name] = session
        return session

    def create_session(self, scene: SceneLike, session_id: str = "") -> "InProcessSession":
        """A new contact of the scene (a dict, a Scene, or a scene file's path); a torsional one
        (InProcessTorsionSession) when the scene has torsion."""
        scene = to_scene(scene)
        kind = _session_kind(scene)
        data = scene.SerializeToString()
        handle = ctypes.c_void_p()
        self._check(kind.function(self._lib, "create")(data, len(data), ctypes.byref(handle)))
        return self._adopt(kind, handle, session_id)

    def session(self, scene: SceneLike, session_id: str = "") -> "InProcessSession":
        """create_session, for a with statement (deleted on exit)."""
        return self.create_session(scene, session_id)

    def import_session(self, snapshot: api.SessionSnapshot,
                       session_id: str = "") -> "InProcessSession":
        """A session continuing a snapshot (from export() here or a server's ExportSession)."""
        kind = _session_kind(snapshot.scene)
        data = snapshot.SerializeToString()
        handle = ctypes.c_void_p()
        self._check(kind.function(self._lib, "restore")(data, len(data), ctypes.byref(handle)))
        return self._adopt(kind, handle, session_id)

    def list_sessions(self) -> list:
        return sorted(self._sessions)


def _session_kind(scene) -> type:
    return InProcessTorsionSession if scene.HasField("torsion") else InProcessSession


def _without_prefix(message: str, field: str) -> str:
    return message[len(field) + 2:] if message.startswith(field + ": ") else message


class InProcessSession:
    """A contact in this process with Session's API (apply, query, export, delete)."""

    _HANDLE = "mdr_contact"  # the C functions' prefix: mdr_contact_create, ..._step, ...

    @classmethod
    def function(cls, lib: ctypes.CDLL, name: str):
        return getattr(lib, f"{cls._HANDLE}_{name}")

    def __init__(self, client: InProcessClient, name: str, handle: ctypes.c_void_p):
        self.client = client
        self.name = name
        self._handle = handle

    def __enter__(self) -> "InProcessSession":
        return self

    def __exit__(self, *exc) -> None:
        self.delete()

    def __repr__(self) -> str:
        return f"InProcessSession({self.name!r})"

    @property
    def _lib(self):
        return self.client._lib

    def _live(self) -> ctypes.c_void_p:
        if not self._handle:
            raise MdrError(grpc.StatusCode.NOT_FOUND, "name", f"{self.name} was deleted")
        return self._handle

    def delete(self) -> None:
        if self._handle:
            self.function(self._lib, "destroy")(self._handle)
            self._handle = None
            self.client._sessions.pop(self.name, None)

    def export(self) -> api.SessionSnapshot:
        snapshot_of = self.function(self._lib, "snapshot")
        size = ctypes.c_size_t()
        status = snapshot_of(self._live(), None, 0, ctypes.byref(size))
        if status != _OUT_OF_RANGE:
            self.client._check(status)
        buffer = ctypes.create_string_buffer(size.value)
        self.client._check(snapshot_of(self._handle, buffer, size, ctypes.byref(size)))
        snapshot = api.SessionSnapshot()
        snapshot.ParseFromString(buffer.raw[:size.value])
        snapshot.source_name = self.name
        return snapshot

    def _state(self) -> api.ContactState:
        raw = _State()
        self.client._check(self._lib.mdr_contact_state(self._live(), ctypes.byref(raw)))
        state = api.ContactState(applied_steps=raw.applied_steps,
                                 memory_vertices=raw.memory_vertices)
        for name in _STATE_DOUBLES[:-1]:  # last_step_dissipation is the Energy output's
            setattr(state, name, getattr(raw, name))
        return state

    def _step(self, step, report: _StepReport) -> None:
        normal = step.WhichOneof("normal")
        tangential = step.WhichOneof("tangential")
        _refuse_per_contact_values(step)
        if step.WhichOneof("torsional"):
            raise MdrError(grpc.StatusCode.INVALID_ARGUMENT, step.WhichOneof("torsional"),
                           "must be unset: only a torsional session (scene.torsion) takes a "
                           "twist")
        self._call_step(step, {"normal_value": normal, "tangential_value": tangential},
                        _NORMAL.get(normal, 0), getattr(step, normal) if normal else 0.0,
                        _TANGENTIAL.get(tangential, 0),
                        getattr(step, tangential) if tangential else 0.0, ctypes.byref(report))

    def _call_step(self, step, fields: dict, *arguments) -> None:
        """The C step on arguments; its errors name the library's arguments, which `fields` maps
        to the Step's fields that the service names."""
        try:
            self.client._check(self.function(self._lib, "step")(self._live(), *arguments))
        except MdrError as error:
            field = fields.get(error.field)
            if not field:
                raise
            raise MdrError(error.code, field, _without_prefix(error.message, field)) from None

    def apply(self, steps: Union[StepLike, Iterable[StepLike]],
              outputs: Sequence[str] = ("state",), request_id: str = "",
              state_fields: Sequence[str] = ()) -> ApplyResult:
        """Session.apply in this process: the steps as one atomic batch (on a failure the
        session is restored to its state before the batch and MdrError names steps[i]).
        state_fields: the ContactState fields of the final state returned (() for all)."""
        steps = to_steps(steps)
        unknown = [path for path in outputs if path.split(".")[0] not in _STEP_OUTPUTS]
        if unknown:
            raise MdrError(grpc.StatusCode.INVALID_ARGUMENT, "step_mask",
                           f"unknown paths {unknown}; known: {list(_STEP_OUTPUTS)}")
        known = api.ContactState.DESCRIPTOR.fields_by_name
        for i, path in enumerate(state_fields):
            if path not in known:
                raise MdrError(grpc.StatusCode.INVALID_ARGUMENT, f"state_mask.paths[{i}]",
                               f"{path!r} is not a field of ContactState; valid: "
                               f"{', '.join(known)}")
        before = self.export() if len(steps) > 1 else None
        response = api.ApplyResponse()
        report = _StepReport()
        for i, step in enumerate(steps):
            try:
                self._step(step, report)
            except MdrError as error:
                if before is not None and i > 0:
                    self._restore(before)
                prefix = f"steps[{i}]"
                raise MdrError(error.code, f"{prefix}.{error.field}" if error.field else prefix,
                               error.message) from None
            if outputs:
                result = response.step_results.add()
                if any(path.startswith("state") for path in outputs):
                    result.state.CopyFrom(self._state())
                if "substeps" in outputs:
                    result.substeps = report.substeps
                if "path_error" in outputs:
                    result.path_error = report.path_error
                if "dissipated_energy" in outputs:
                    result.dissipated_energy = report.dissipated
        state = self._state()
        if state_fields:
            for name in known:
                if name not in state_fields:
                    state.ClearField(name)
        response.state.CopyFrom(state)
        return ApplyResult.of(response)

    def _restore(self, snapshot: api.SessionSnapshot) -> None:
        data = snapshot.SerializeToString()
        handle = ctypes.c_void_p()
        self.client._check(self.function(self._lib, "restore")(data, len(data),
                                                               ctypes.byref(handle)))
        self.function(self._lib, "destroy")(self._handle)
        self._handle = handle

    def _sized(self, function, kinds, *extra):
        """Calls function(contact, arrays..., capacity, &count, *extra): sizes, then values."""
        count = ctypes.c_size_t()
        status = function(self._live(), *[None] * len(kinds), 0, ctypes.byref(count), *extra)
        if status != _OUT_OF_RANGE:
            self.client._check(status)
        arrays = [(kind * max(count.value, 1))() for kind in kinds]
        self.client._check(function(self._handle, *arrays, count.value, ctypes.byref(count),
                                    *extra))
        return arrays, count.value

    def query(self, outputs: Sequence[str] = ("state",), radii: Sequence[float] = (),
              route: str = "both") -> QueryResult:
        """Session.query in this process: "state", "tangential_stiffness", "slip_intervals",
        "jager_weights", "tractions" and "pressure" (the others need a server)."""
        if any(path.split(".")[0] == "torsion" for path in outputs):
            raise MdrError(grpc.StatusCode.FAILED_PRECONDITION, "read_mask",
                           '"torsion.*" outputs need a torsional session (scene.torsion)')
        unknown = [path for path in outputs if path.split(".")[0] not in _QUERY_OUTPUTS]
        if unknown:
            raise MdrError(grpc.StatusCode.INVALID_ARGUMENT, "read_mask",
                           f"{unknown} are not available in process; available: "
                           f"{list(_QUERY_OUTPUTS)}")
        if route not in _ROUTES:
            raise ValueError(f"route must be one of {sorted(_ROUTES)}, got {route!r}")
        response = api.QueryResponse()
        if "state" in outputs or not outputs:
            response.state.CopyFrom(self._state())
        if any(path.startswith("tangential_stiffness") for path in outputs):
            positive, negative = ctypes.c_double(), ctypes.c_double()
            self.client._check(self._lib.mdr_contact_stiffness(self._live(), positive, negative))
            response.tangential_stiffness.positive = positive.value
            response.tangential_stiffness.negative = negative.value
        if "slip_intervals" in outputs:
            (begin, end, direction), n = self._sized(
                self._lib.mdr_contact_slip_intervals, (ctypes.c_double, ctypes.c_double,
                                                       ctypes.c_int32))
            for i in range(n):
                response.slip_intervals.add(r_begin=begin[i], r_end=end[i],
                                            direction=direction[i])
        if "jager_weights" in outputs:
            edge = ctypes.c_double()
            (begin, end, weight), n = self._sized(self._lib.mdr_contact_jager_weights,
                                                  (ctypes.c_double,) * 3, ctypes.byref(edge))
            weights = response.jager_weights
            weights.contact_radius = self._state().contact_radius
            weights.edge_weight = edge.value
            for i in range(n):
                weights.intervals.add(r_begin=begin[i], r_end=end[i], weight=weight[i])
        if "tractions" in outputs or "pressure" in outputs:
            self._radial(response, list(radii), outputs, route)
        return QueryResult.of(response)

    def _radial(self, response, radii, outputs, route) -> None:
        n = len(radii)
        if n == 0:
            raise MdrError(grpc.StatusCode.INVALID_ARGUMENT, "radii",
                           "required (at least one radius) when tractions or pressure are read")
        values = [(ctypes.c_double * n)() for _ in range(4)]
        tau, tau_error, p, p_error = values
        self.client._check(self._lib.mdr_contact_tractions(
            self._live(), (ctypes.c_double * n)(*radii), n, _ROUTES[route],
            tau if "tractions" in outputs else None, tau_error if "tractions" in outputs else None,
            p if "pressure" in outputs else None, p_error if "pressure" in outputs else None, n))
        for name, value, error in (("tractions", tau, tau_error), ("pressure", p, p_error)):
            if name in outputs:
                for i in range(n):
                    getattr(response, name).add(radius=radii[i], value=value[i],
                                                error_estimate=error[i])


def _refuse_per_contact_values(step) -> None:
    if step.contact_normal_values or step.contact_tangential_values:
        raise MdrError(grpc.StatusCode.INVALID_ARGUMENT, "contact_normal_values",
                       "per-contact values are for contact list sessions (a server's)")


class InProcessTorsionSession(InProcessSession):
    """A torsional contact (scene.torsion) in this process, through mdr_torsion: steps move the
    normal channel or the twist (twist, twist_increment, twisting_moment), one per step; query
    reads "state" and "torsion.*" (stiffness, slip_intervals, tractions at radii, memory_pieces,
    stored_energy), as a server's torsional session answers them."""

    _HANDLE = "mdr_torsion"

    def _state(self) -> api.ContactState:
        raw = _TorsionalState()
        self.client._check(self._lib.mdr_torsion_state(self._live(), ctypes.byref(raw)))
        # The service's torsional state: no rig, so the actuator's depth is the contact's.
        state = api.ContactState(applied_steps=raw.applied_steps,
                                 memory_vertices=raw.memory_pieces, actuator_depth=raw.depth)
        for name in _TORSIONAL_STATE_DOUBLES:
            if name != "last_step_dissipation":  # the Energy output's, not the state's
                setattr(state, name, getattr(raw, name))
        return state

    def _step(self, step, report: _StepReport) -> None:
        normal = step.WhichOneof("normal")
        twist = step.WhichOneof("torsional")
        _refuse_per_contact_values(step)
        if step.WhichOneof("tangential"):  # mdr_torsion_step has no tangential channel
            raise MdrError(grpc.StatusCode.INVALID_ARGUMENT, step.WhichOneof("tangential"),
                           _TANGENTIAL_IN_TORSION)
        # Both channels in one step: the library names the twist's control, the service its field.
        self._call_step(step, {"normal_value": normal, "twist_value": twist,
                               "twist_control": twist},
                        _NORMAL.get(normal, 0), getattr(step, normal) if normal else 0.0,
                        _TWIST.get(twist, 0), getattr(step, twist) if twist else 0.0,
                        ctypes.byref(report))

    def query(self, outputs: Sequence[str] = ("state",), radii: Sequence[float] = (),
              route: str = "both") -> QueryResult:
        """Session.query of a torsional session in this process: "state" and "torsion" or its
        fields "torsion.stiffness", "torsion.slip_intervals", "torsion.tractions" (at radii),
        "torsion.memory_pieces", "torsion.stored_energy". route is not used (tau_phi has its
        two routes in value and route_difference)."""
        selected = set()
        for path in outputs:
            head, _, rest = path.partition(".")
            if head == "state" and not rest:
                continue
            if head != "torsion" or (rest and rest not in _TORSION_OUTPUTS):
                raise MdrError(grpc.StatusCode.FAILED_PRECONDITION, "read_mask",
                               f"{path!r}: a torsional session in process answers \"state\" "
                               f"and \"torsion\" or its fields {list(_TORSION_OUTPUTS)}")
            selected.update([rest] if rest else _TORSION_OUTPUTS)
        response = api.QueryResponse()
        if "state" in outputs or not outputs:
            response.state.CopyFrom(self._state())
        torsion = response.torsion
        if "stiffness" in selected:
            positive, negative = ctypes.c_double(), ctypes.c_double()
            self.client._check(self._lib.mdr_torsion_stiffness(self._live(), positive, negative))
            torsion.stiffness_positive, torsion.stiffness_negative = positive.value, negative.value
        if "slip_intervals" in selected:
            (begin, end, direction), n = self._sized(
                self._lib.mdr_torsion_slip_intervals, (ctypes.c_double, ctypes.c_double,
                                                       ctypes.c_int32))
            for i in range(n):
                torsion.slip_intervals.add(r_begin=begin[i], r_end=end[i], direction=direction[i])
        if "tractions" in selected:
            self._tractions(torsion, list(radii))
        if "memory_pieces" in selected:  # the snapshot holds the memory, piece by piece
            torsion.memory_pieces.extend(self.export().torsion.pieces)
        if "stored_energy" in selected:
            energy = ctypes.c_double()
            self.client._check(self._lib.mdr_torsion_stored_energy(self._live(), energy))
            torsion.stored_energy = energy.value
        if not selected:
            response.ClearField("torsion")
        return QueryResult.of(response)

    def _tractions(self, torsion, radii) -> None:
        n = len(radii)
        if n == 0:
            raise MdrError(grpc.StatusCode.INVALID_ARGUMENT, "radii",
                           "required (at least one radius) when torsion.tractions are read")
        value, difference = (ctypes.c_double * n)(), (ctypes.c_double * n)()
        self.client._check(self._lib.mdr_torsion_tractions(
            self._live(), (ctypes.c_double * n)(*radii), n, value, difference, n))
        for i in range(n):
            torsion.tractions.add(radius=radii[i], value=value[i],
                                  route_difference=difference[i])
