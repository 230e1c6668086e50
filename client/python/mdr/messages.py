"""Scenes, steps and scene files from dicts, protos or files; results as numpy arrays."""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from typing import Iterable, Mapping, Sequence, Union

import numpy as np
from google.protobuf import json_format

from mdr.v1 import contact_service_pb2 as api
from mdr.v1 import scene_file_pb2, scene_pb2

SceneLike = Union[scene_pb2.Scene, Mapping, str, os.PathLike]
StepLike = Union[scene_pb2.Step, Mapping]

# Per-step state fields, in the order of ContactState.
STATE_FIELDS = ("depth", "tangential_displacement", "contact_radius", "normal_force",
                "tangential_force", "dissipated_energy", "friction_limit", "applied_steps",
                "memory_vertices")


def _json_numbers(data):
    """data with non-finite floats spelled as proto3 JSON spells them ("NaN", "Infinity"), so
    that the server, not the parser, judges them and names the field."""
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
    if str(path).endswith((".yaml", ".yml")):
        import yaml  # python3-yaml

        # YAML 1.1 reads "210e9" (no dot) as a string; proto3 JSON accepts numeric strings.
        data = yaml.safe_load(text) or {}
    else:
        data = json.loads(text)
    return _parse(data, scene_file_pb2.SceneFile())


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


@dataclass
class QueryResult:
    """The selected outputs of a session's state.

    tractions / pressure: dicts of numpy arrays (radius, value, error_estimate) when selected;
    springs: dict of numpy arrays (tangential_displacement, normal_displacement) over the radii;
    response: the QueryResponse as received, for everything else (slip intervals, weights...).
    """
    state: api.ContactState
    tractions: dict
    pressure: dict
    springs: dict
    response: api.QueryResponse

    @classmethod
    def of(cls, response: api.QueryResponse) -> "QueryResult":
        springs = {
            "tangential_displacement": np.array(response.springs.tangential_displacement),
            "normal_displacement": np.array(response.springs.normal_displacement),
        }
        return cls(response.state, radial_arrays(response.tractions),
                   radial_arrays(response.pressure), springs, response)
