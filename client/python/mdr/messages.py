"""Scenes, steps and scene files from dicts, protos or files; interface scenes and contact-list
steps from numpy arrays; results as numpy arrays."""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from typing import Iterable, Mapping, Optional, Sequence, Union

import numpy as np
from google.protobuf import json_format

from mdr.v1 import contact_service_pb2 as api
from mdr.v1 import scene_file_pb2, scene_pb2

SceneLike = Union[scene_pb2.Scene, Mapping, str, os.PathLike]
StepLike = Union[scene_pb2.Step, Mapping]

# Per-step state fields, in the order of ContactState (a torsional session's twist in rad,
# twisting_moment and full_slip_moment in N m; 0 in other sessions).
STATE_FIELDS = ("depth", "tangential_displacement", "contact_radius", "normal_force",
                "tangential_force", "dissipated_energy", "friction_limit", "applied_steps",
                "memory_vertices", "actuator_displacement", "actuator_depth", "twist",
                "twisting_moment", "full_slip_moment")


def _json_numbers(data):
    """data with non-finite floats spelled as proto3 JSON spells them ("NaN", "Infinity"), so
    that the server, not the parser, judges them and names the field."""
    if isinstance(data, (np.ndarray, np.generic)):
        data = data.tolist()
    if isinstance(data, float) and not math.isfinite(data):
        return "NaN" if math.isnan(data) else ("Infinity" if data > 0 else "-Infinity")
    if isinstance(data, Mapping):
        return {key: _json_numbers(value) for key, value in data.items()}
    if isinstance(data, (list, tuple)):
        return [_json_numbers(value) for value in data]
    return data


def _parse(data: Mapping, message):
    """data (proto field names or JSON names, as in mdrctl's scene files) into message."""
    try:
        return json_format.ParseDict(_json_numbers(data), message)
    except json_format.ParseError as error:
        raise ValueError(f"{type(message).DESCRIPTOR.full_name}: {error}") from None


def load_scene_file(path: Union[str, os.PathLike]) -> scene_file_pb2.SceneFile:
    """A YAML or JSON scene file, the format mdrctl reads (mdr.v1.SceneFile)."""
    with open(path, encoding="utf-8") as stream:
        text = stream.read()
    try:
        if str(path).endswith((".yaml", ".yml")):
            import yaml  # python3-yaml

            # YAML 1.1 reads "210e9" (no dot) as a string; proto3 JSON accepts numeric strings.
            data = yaml.safe_load(text) or {}
        else:
            data = json.loads(text)
        return _parse(data, scene_file_pb2.SceneFile())
    except RecursionError:  # the parsers recurse per level: a ValueError, as for mdrctl
        raise ValueError(f"{os.fspath(path)}: nested too deep to parse") from None


def to_scene(scene: SceneLike) -> scene_pb2.Scene:
    """A Scene from a proto, a dict, or a scene file (its `scene`)."""
    if isinstance(scene, scene_pb2.Scene):
        return scene
    if isinstance(scene, (str, os.PathLike)):
        return load_scene_file(scene).scene
    return _parse(scene, scene_pb2.Scene())


def to_step(step: StepLike) -> scene_pb2.Step:
    """A Step from a proto or a dict such as {"normal_force": 100, "displacement": 1e-7}."""
    if isinstance(step, scene_pb2.Step):
        return step
    return _parse(step, scene_pb2.Step())


def to_steps(steps: Union[StepLike, Iterable[StepLike]]) -> list:
    if isinstance(steps, (scene_pb2.Step, Mapping)):
        return [to_step(steps)]
    return [to_step(step) for step in steps]


_KINDS = {"shared_motion": scene_pb2.Interface.KIND_SHARED_MOTION,
          "contact_list": scene_pb2.Interface.KIND_CONTACT_LIST}


def _packed(name: str, values) -> np.ndarray:
    """values (a sequence or numpy array) as a 1-D float64 array for a packed repeated field.
    Non-finite values pass, so that the server judges them and names the field."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional (one value per contact), got shape "
                         f"{array.shape}")
    return array


def interface_scene(scene: SceneLike, kind: str, *, heights=None, radii=None,
                    generated: Optional[Union[scene_pb2.GeneratedPopulation, Mapping]] = None
                    ) -> scene_pb2.Scene:
    """An interface scene (Scene.interface): a copy of `scene`, whose profile, material, friction
    and options every contact has, with N contacts of kind "shared_motion" (one rigid motion) or
    "contact_list" (every step carries one value per contact: contact_step).

    The population is either explicit: heights (summit heights in m) and optionally radii (one
    per height, for a sphere scene), sequences or numpy arrays packed as they are; a contact list
    does not use heights but counts them (np.zeros(N)). Or generated: a GeneratedPopulation or a
    dict of its fields, e.g. {"count": 400, "height_scale": 1e-6, "seed": 7,
    "radius_distribution": "RADIUS_DISTRIBUTION_LOGNORMAL", "log_sigma": 0.2}. The server
    checks the ranges (errors name scene.interface.generated.count and so on)."""
    if kind not in _KINDS:
        raise ValueError(f"kind must be one of {sorted(_KINDS)}, got {kind!r}")
    if (heights is None) == (generated is None):
        raise ValueError("interface_scene needs exactly one population: heights (explicit) or "
                         "generated")
    if generated is not None and radii is not None:
        raise ValueError("radii belong to an explicit population (heights); a generated one "
                         "takes radius_distribution")
    result = scene_pb2.Scene()
    result.CopyFrom(to_scene(scene))
    result.ClearField("interface")
    result.interface.kind = _KINDS[kind]
    if generated is not None:
        if isinstance(generated, scene_pb2.GeneratedPopulation):
            result.interface.generated.CopyFrom(generated)
        else:
            _parse(generated, result.interface.generated)
        return result
    population = result.interface.explicit_list
    population.heights.extend(_packed("heights", heights))
    if radii is not None:
        population.radii.extend(_packed("radii", radii))
    return result


def contact_step(*, depth=None, depth_increment=None, normal_force=None, displacement=None,
                 displacement_increment=None, tangential_force=None) -> scene_pb2.Step:
    """A step of a contact list: per channel at most one keyword, whose values (a sequence or
    numpy array of N values, in contact order) are packed into Step.contact_normal_values or
    contact_tangential_values. The keyword is the control every contact takes (Step's oneof, set
    to 0 as the proto asks): depth (its target depth), depth_increment (its change of depth),
    normal_force (its own force target); displacement, displacement_increment, tangential_force
    likewise. A channel without a keyword holds every contact. E.g.
    contact_step(depth_increment=dz, displacement=ux). The server checks the count and every
    value (steps[0].contact_normal_values: must hold one value per contact (3), got 2)."""
    step = scene_pb2.Step()
    channels = (("contact_normal_values", {"depth": depth, "depth_increment": depth_increment,
                                           "normal_force": normal_force}),
                ("contact_tangential_values", {"displacement": displacement,
                                               "displacement_increment": displacement_increment,
                                               "tangential_force": tangential_force}))
    for field, controls in channels:
        chosen = [name for name, values in controls.items() if values is not None]
        if len(chosen) > 1:
            raise ValueError(f"contact_step takes at most one of {', '.join(controls)}, got "
                             f"{' and '.join(chosen)}")
        if chosen:
            setattr(step, chosen[0], 0.0)  # selects the oneof: the values are per contact
            getattr(step, field).extend(_packed(chosen[0], controls[chosen[0]]))
    return step


def state_arrays(states: Sequence[api.ContactState]) -> dict:
    """One numpy array per ContactState field, over the given states."""
    return {name: np.array([getattr(state, name) for state in states],
                           dtype=np.uint64 if name in ("applied_steps", "memory_vertices")
                           else np.float64)
            for name in STATE_FIELDS}


@dataclass
class ApplyResult:
    """The result of one atomic batch.

    state: the ContactState after the batch; steps: numpy arrays of the per-step states (empty
    arrays unless the step mask asked for "state"); response: the ApplyResponse as received.
    """
    state: api.ContactState
    steps: dict
    response: api.ApplyResponse

    def __getattr__(self, name):
        if name in STATE_FIELDS:
            return self.steps[name]
        raise AttributeError(name)

    @classmethod
    def of(cls, response: api.ApplyResponse) -> "ApplyResult":
        states = [result.state for result in response.step_results if result.HasField("state")]
        return cls(response.state, state_arrays(states), response)


def radial_arrays(values: Sequence[api.RadialValue]) -> dict:
    """radius, value and error_estimate over the sampled radii (tractions or pressure)."""
    return {
        "radius": np.array([v.radius for v in values]),
        "value": np.array([v.value for v in values]),
        "error_estimate": np.array([v.error_estimate for v in values]),
    }


@dataclass(frozen=True)
class InterfaceTotals:
    """Totals over an interface's contacts (mdr.v1.InterfaceTotals), each summed in contact
    order: forces in N, energies in J (since the start and of the last step), friction_limit
    the sum of mu F_N, stiffnesses in N/m (tangential toward +x and -x), and the numbers of
    contacts in contact and, of those, sticking, in partial slip and in gross slip."""
    normal_force: float
    tangential_force: float
    dissipated_energy: float
    last_step_dissipated_energy: float
    friction_limit: float
    normal_stiffness: float
    tangential_stiffness_positive: float
    tangential_stiffness_negative: float
    in_contact: int
    sticking: int
    partial_slip: int
    gross_slip: int

    @classmethod
    def of(cls, totals: api.InterfaceTotals) -> "InterfaceTotals":
        stiffness = totals.tangential_stiffness
        return cls(totals.normal_force, totals.tangential_force, totals.dissipated_energy,
                   totals.last_step_dissipated_energy, totals.friction_limit,
                   totals.normal_stiffness, stiffness.positive, stiffness.negative,
                   totals.in_contact, totals.sticking, totals.partial_slip, totals.gross_slip)


@dataclass
class InterfaceResult:
    """The "interface.*" outputs of an interface session (mdr.v1.InterfaceOutputs).

    contact_count: N, always; totals: an InterfaceTotals when "interface.totals" was selected,
    else None; slip_histogram: numpy array (uint64) of the contacts in contact per slip-fraction
    bin, empty unless "interface.slip_histogram" was selected; memory_bytes: the interface's
    estimate, 0 unless "interface.memory_bytes" was selected.
    """
    contact_count: int
    totals: Optional[InterfaceTotals]
    slip_histogram: np.ndarray
    memory_bytes: int

    @classmethod
    def of(cls, outputs: api.InterfaceOutputs) -> "InterfaceResult":
        totals = InterfaceTotals.of(outputs.totals) if outputs.HasField("totals") else None
        return cls(outputs.contact_count, totals,
                   np.array(outputs.slip_histogram, dtype=np.uint64), outputs.memory_bytes)


@dataclass
class QueryResult:
    """The selected outputs of a session's state.

    state: the session's state (an interface's without contact_index, else that contact's);
    tractions / pressure: dicts of numpy arrays (radius, value, error_estimate) when selected;
    springs: dict of numpy arrays (tangential_displacement, normal_displacement) over the radii;
    interface: an InterfaceResult when an "interface.*" path was selected, else None;
    response: the QueryResponse as received, for everything else (slip intervals, weights...).
    """
    state: api.ContactState
    tractions: dict
    pressure: dict
    springs: dict
    response: api.QueryResponse
    interface: Optional[InterfaceResult] = None

    @classmethod
    def of(cls, response: api.QueryResponse) -> "QueryResult":
        springs = {
            "tangential_displacement": np.array(response.springs.tangential_displacement),
            "normal_displacement": np.array(response.springs.normal_displacement),
        }
        interface = (InterfaceResult.of(response.interface)
                     if response.HasField("interface") else None)
        return cls(response.state, radial_arrays(response.tractions),
                   radial_arrays(response.pressure), springs, response, interface)
