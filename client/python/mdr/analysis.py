"""The analysis of measured friction loops (docs/analysis.md): requests of AnalyzeLoops, FitLoops,
FrettingMap and Backbone from numpy arrays, and their answers as numpy arrays. All values are SI
(m, N, J, s, N/m, Pa, m/N). A torsional record (a ball twisted on a flat: twist in rad, twisting
moment in N m) keeps every figure's definition with phi for u and M for F_x, so its figures are
in rad, N m, J and N m/rad and its compliance in rad/(N m) (docs/analysis.md, "Torsional
records"). Client's analyze_loops, fit_loops, fretting_map and backbone use it.
"""
from __future__ import annotations

import abc
import dataclasses
from dataclasses import dataclass
from typing import Callable, Iterator, Mapping, NamedTuple, Optional, Sequence

import numpy as np
from google.protobuf import descriptor

from mdr.v1 import analysis_pb2 as an
from mdr.v1 import scene_pb2

from .messages import SceneLike, to_scene

# FitParameter values by name: "friction", "effective_modulus", "profile_scale",
# "rig_compliance", "displacement_offset", "torsional_modulus".
_PARAMETERS = {value.name.removeprefix("FIT_PARAMETER_").lower(): value.number
               for value in an.FitParameter.DESCRIPTOR.values if value.number != 0}
_PARAMETER_NAMES = {number: name for name, number in _PARAMETERS.items()}
FIT_PARAMETERS = tuple(_PARAMETERS)

_MEASURES = {an.MEASURES_CONTACT: "contact", an.MEASURES_CONTACT_AND_RIG: "contact+rig"}
_KINDS = {"force": an.BackboneRequest.AMPLITUDE_KIND_FORCE,
          "actuator_displacement": an.BackboneRequest.AMPLITUDE_KIND_ACTUATOR_DISPLACEMENT}
_FREE_KEYS = ("initial", "lower", "upper")

_FD = descriptor.FieldDescriptor
_INTEGERS = (_FD.TYPE_UINT64, _FD.TYPE_INT64, _FD.TYPE_UINT32, _FD.TYPE_INT32)


def _enum_name(enum: descriptor.EnumDescriptor, number: int) -> str:
    """"REGIME_GROSS_SLIP" -> "gross_slip" (the prefix is the enum's name in upper snake case)."""
    value = enum.values_by_number.get(number)
    if value is None:
        return str(number)
    prefix = "".join("_" + c if c.isupper() else c for c in enum.name).lstrip("_").upper() + "_"
    return value.name.removeprefix(prefix).lower()


# Conversion of the requests' inputs.
def _column(name: str, values, scalar: bool = False) -> np.ndarray:
    """values (a sequence or numpy array; with scalar, also one number) as a 1-D float64 array.
    Non-finite values pass: the server names them (e.g. samples.displacement[12])."""
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name}: {error}") from None
    if scalar and array.ndim == 0:
        return array.reshape(1)
    if array.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {array.shape}")
    return array


def _number(name: str, value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None


def _varint(value: int) -> bytes:
    out = bytearray()
    while True:
        byte = value & 0x7F
        value >>= 7
        if value:
            out.append(byte | 0x80)
        else:
            out.append(byte)
            return bytes(out)


def _pack_doubles(message, field: str, array: np.ndarray) -> None:
    """Appends array to a packed repeated double field as wire bytes: the same message as
    extend(), without a Python call per value (10^6 values: about 20 ms against 0.1 s)."""
    if array.size == 0:
        return
    number = type(message).DESCRIPTOR.fields_by_name[field].number
    payload = array.astype("<f8", copy=False).tobytes()
    message.MergeFromString(_varint(number << 3 | 2) + _varint(len(payload)) + payload)


def loop_samples(displacement=None, tangential_force=None, normal_force=None, time=None,
                 prefix: str = "", *, twist=None, twisting_moment=None) -> an.LoopSamples:
    """A LoopSamples from columns, one value per sample: displacement u (m) and tangential_force
    F_x (N), or for a torsional record twist phi (rad) and twisting_moment M (N m); optionally
    normal_force F_N (N) and time t (s). Every given column is sent: the server checks lengths,
    values and that a record holds one pair, not both, and names the column or the sample."""
    samples = an.LoopSamples()
    columns = (("displacement", displacement), ("tangential_force", tangential_force),
               ("twist", twist), ("twisting_moment", twisting_moment),
               ("normal_force", normal_force), ("time", time))
    for name, values in columns:
        if values is not None:
            _pack_doubles(samples, name, _column(prefix + name, values))
    return samples


def analyze_request(displacement=None, tangential_force=None, normal_force=None, time=None, *,
                    twist=None, twisting_moment=None,
                    scene: Optional[SceneLike] = None, rig_compliance: Optional[float] = None,
                    reversal_threshold: float = 0.0, displacement_resolution: float = 0.0,
                    closure_tolerance: Optional[float] = None,
                    asymmetry_tolerance: Optional[float] = None,
                    hook_tolerance: Optional[float] = None,
                    drift_tolerance: Optional[float] = None) -> an.AnalyzeLoopsRequest:
    """The AnalyzeLoopsRequest of Client.analyze_loops (its arguments)."""
    constant = normal_force is not None and np.ndim(normal_force) == 0
    request = an.AnalyzeLoopsRequest(samples=loop_samples(
        displacement, tangential_force, None if constant else normal_force, time, twist=twist,
        twisting_moment=twisting_moment))
    options = request.options
    if constant:
        options.normal_force = _number("normal_force", normal_force)
    options.reversal_threshold = _number("reversal_threshold", reversal_threshold)
    options.displacement_resolution = _number("displacement_resolution",
                                              displacement_resolution)
    for name, value in (("rig_compliance", rig_compliance),
                        ("closure_tolerance", closure_tolerance),
                        ("asymmetry_tolerance", asymmetry_tolerance),
                        ("hook_tolerance", hook_tolerance), ("drift_tolerance", drift_tolerance)):
        if value is not None:
            setattr(options, name, _number(name, value))
    if scene is not None:
        request.scene.CopyFrom(to_scene(scene))
    return request


_SET_KEYS = ("displacement", "tangential_force", "twist", "twisting_moment", "normal_force",
             "time", "declared_normal_force")
# A set's loop columns by channel: a tuple's first two items, a dict's keys.
_PAIRS = {False: ("displacement", "tangential_force"), True: ("twist", "twisting_moment")}


def _loop_set(index: int, item, torsional: bool = False) -> an.FitLoopsRequest.LoopSet:
    """One loop set: (displacement, tangential_force, normal_force[, time]) (a torsional fit's:
    (twist, twisting_moment, normal_force[, time])), a dict with those keys (and optionally
    declared_normal_force), or a FitLoopsRequest.LoopSet. normal_force is one number (the set's
    constant load, N) or an array (the measured normal force, replayed as measured;
    declared_normal_force is then checked against it)."""
    if isinstance(item, an.FitLoopsRequest.LoopSet):
        return item
    name = f"sets[{index}]"
    pair = _PAIRS[torsional]
    columns = {}
    declared = None
    if isinstance(item, Mapping):
        unknown = sorted(set(item) - set(_SET_KEYS))
        if unknown:
            raise ValueError(f"{name}: unknown key {unknown[0]!r} (a set has "
                             f"{', '.join(_SET_KEYS)})")
        if "normal_force" not in item:
            raise ValueError(f"{name} needs normal_force")
        if not any(key in item for key in _PAIRS[False] + _PAIRS[True]):
            raise ValueError(f"{name} needs {' and '.join(pair)}")
        columns = {key: item[key] for key in _PAIRS[False] + _PAIRS[True] if key in item}
        load, time, declared = item["normal_force"], item.get("time"), item.get(
            "declared_normal_force")
    else:
        shape = f"({', '.join(pair)}, normal_force[, time])"
        try:
            position, force, load, *rest = item
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be {shape} or a dict of them") from None
        if len(rest) > 1:
            raise ValueError(f"{name} must be {shape}, got {len(rest) + 3} items")
        columns = dict(zip(pair, (position, force)))
        time = rest[0] if rest else None
    column = np.ndim(load) != 0
    if not column and declared is not None:
        raise ValueError(f"{name}.declared_normal_force needs normal_force as a column")
    loop_set = an.FitLoopsRequest.LoopSet(
        samples=loop_samples(normal_force=load if column else None, time=time,
                             prefix=f"{name}.samples.", **columns))
    if not column:
        loop_set.normal_force = _number(f"{name}.normal_force", load)
    elif declared is not None:
        loop_set.normal_force = _number(f"{name}.declared_normal_force", declared)
    return loop_set


def _parameter(name) -> int:
    if name not in _PARAMETERS:
        raise ValueError(f"unknown fit parameter {name!r}: expected one of "
                         f"{', '.join(FIT_PARAMETERS)}")
    return _PARAMETERS[name]


def _free_parameter(name, bounds, where: str) -> an.FitLoopsRequest.FreeParameter:
    number = _parameter(name)
    if not isinstance(bounds, Mapping):
        raise ValueError(f"{where} ({name}) must be a dict with lower, upper and optionally "
                         f"initial, got {bounds!r}")
    unknown = sorted(set(bounds) - set(_FREE_KEYS))
    if unknown:
        raise ValueError(f"{where} ({name}): unknown key {unknown[0]!r} (expected lower, upper, "
                         f"initial)")
    for key in ("lower", "upper"):
        if key not in bounds:
            raise ValueError(f"{where} ({name}) needs {key}")
    free = an.FitLoopsRequest.FreeParameter(
        parameter=number, lower=_number(f"{where}.lower", bounds["lower"]),
        upper=_number(f"{where}.upper", bounds["upper"]))
    if bounds.get("initial") is not None:
        free.initial = _number(f"{where}.initial", bounds["initial"])
    return free


def free_parameters(free) -> list:
    """FreeParameter messages from {"friction": {"lower": 0.1, "upper": 1, "initial": 0.4}, ...}
    (in the dict's order) or a list of dicts with a "parameter" key besides those, or of
    FreeParameter messages."""
    if isinstance(free, Mapping):
        return [_free_parameter(name, bounds, f"free[{k}]")
                for k, (name, bounds) in enumerate(free.items())]
    result = []
    for k, item in enumerate(free):
        if isinstance(item, an.FitLoopsRequest.FreeParameter):
            result.append(item)
            continue
        if not isinstance(item, Mapping) or "parameter" not in item:
            raise ValueError(f"free[{k}] must be a dict with parameter, lower, upper (and "
                             f"optionally initial), got {item!r}")
        bounds = {key: value for key, value in item.items() if key != "parameter"}
        result.append(_free_parameter(item["parameter"], bounds, f"free[{k}]"))
    return result


NUISANCES = ("force_offset", "displacement_drift", "moving_mass")


def fit_request(scene: SceneLike, sets, free, *, burn_in_reversals: Optional[int] = None,
                reversal_threshold: float = 0.0, max_iterations: int = 0, nuisances=(),
                displacement_noise: Optional[float] = None, force_noise: Optional[float] = None,
                include_models: bool = False) -> an.FitLoopsRequest:
    """The FitLoopsRequest of Client.fit_loops (its arguments)."""
    request = an.FitLoopsRequest(scene=to_scene(scene),
                                 reversal_threshold=_number("reversal_threshold",
                                                            reversal_threshold),
                                 include_models=bool(include_models))
    # The scene decides a tuple's columns: with torsion, (twist, twisting_moment, ...).
    torsional = request.scene.HasField("torsion")
    request.sets.extend(_loop_set(i, item, torsional) for i, item in enumerate(sets))
    request.free.extend(free_parameters(free))
    for name, value in (("burn_in_reversals", burn_in_reversals),
                        ("max_iterations", max_iterations)):
        if value is not None and not (isinstance(value, (int, np.integer))
                                      and -2**31 <= value < 2**31):
            raise ValueError(f"{name} must be an integer fitting the request's int32, got "
                             f"{value!r}")
    if burn_in_reversals is not None:
        request.burn_in_reversals = int(burn_in_reversals)
    request.max_iterations = int(max_iterations)
    if isinstance(nuisances, str):
        nuisances = (nuisances,)
    for nuisance in nuisances:
        if nuisance not in NUISANCES:
            raise ValueError(f"unknown nuisance {nuisance!r}: expected one of "
                             f"{', '.join(NUISANCES)} (every set's displacement offset is "
                             f"fitted always)")
        setattr(request.nuisances, nuisance, True)
    if displacement_noise is not None:
        request.displacement_noise = _number("displacement_noise", displacement_noise)
    if force_noise is not None:
        request.force_noise = _number("force_noise", force_noise)
    return request


def fretting_map_request(scene: SceneLike, normal_forces, relative_amplitudes
                         ) -> an.FrettingMapRequest:
    request = an.FrettingMapRequest(scene=to_scene(scene))
    _pack_doubles(request, "normal_forces", _column("normal_forces", normal_forces, scalar=True))
    _pack_doubles(request, "relative_amplitudes",
                  _column("relative_amplitudes", relative_amplitudes, scalar=True))
    return request


def backbone_request(scene: SceneLike, normal_force: float, amplitudes, kind: str = "force"
                     ) -> an.BackboneRequest:
    if kind not in _KINDS:
        raise ValueError(f"kind must be one of {', '.join(_KINDS)}, got {kind!r}")
    request = an.BackboneRequest(scene=to_scene(scene),
                                 normal_force=_number("normal_force", normal_force),
                                 kind=_KINDS[kind])
    _pack_doubles(request, "amplitudes", _column("amplitudes", amplitudes, scalar=True))
    return request


# Conversion of the answers.
class Figures(Mapping):
    """Named numpy arrays with one value per loop (a cycle, an amplitude), read as attributes
    (f.force_amplitude) or keys (f["force_amplitude"]); iterating gives the names. Doubles are
    float64, sample indices int64, flags bool, regimes strings ("sticking", "partial_slip",
    "gross_slip")."""

    def __init__(self, arrays: dict):
        self._arrays = arrays

    def __getitem__(self, name: str) -> np.ndarray:
        return self._arrays[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._arrays)

    def __len__(self) -> int:
        return len(self._arrays)

    def __getattr__(self, name: str) -> np.ndarray:
        arrays = self.__dict__.get("_arrays", {})
        if name in arrays:
            return arrays[name]
        raise AttributeError(name)

    def __dir__(self):
        return list(super().__dir__()) + list(self._arrays)

    def __repr__(self) -> str:
        shape = next(iter(self._arrays.values())).shape if self._arrays else ()
        return f"Figures(shape={shape}, names={list(self._arrays)})"


def _array(values: list, field: descriptor.FieldDescriptor) -> np.ndarray:
    if field.type == _FD.TYPE_ENUM:
        return np.array([_enum_name(field.enum_type, v) for v in values], dtype=str)
    if field.type == _FD.TYPE_BOOL:
        return np.array(values, dtype=bool)
    if field.type in _INTEGERS:
        return np.array(values, dtype=np.int64)
    return np.array(values, dtype=np.float64)


def figures_of(messages: Sequence, message_type, shape: Optional[tuple] = None,
               skip: Sequence[str] = ()) -> Figures:
    """One array per scalar field of message_type over the messages (reshaped to shape)."""
    arrays = {}
    for field in message_type.DESCRIPTOR.fields:
        if field.type == _FD.TYPE_MESSAGE or field.name in skip:
            continue
        array = _array([getattr(m, field.name) for m in messages], field)
        arrays[field.name] = array.reshape(shape) if shape is not None else array
    return Figures(arrays)


class Estimate(NamedTuple):
    """One fitted parameter: its value, standard error and 95 % interval in the parameter's unit
    (friction: 1; effective_modulus: Pa; profile_scale: m for a sphere's radius;
    rig_compliance: m/N; displacement_offset: m; a torsional fit's rig_compliance: rad/(N m),
    displacement_offset: rad, torsional_modulus: Pa), and whether the data identify it."""
    value: float
    standard_error: float
    lower_95: float
    upper_95: float
    identified: bool


class NuisanceFit(NamedTuple):
    """One fitted nuisance: its name ("force_offset" N, "displacement_offset" m,
    "displacement_drift" m over the set, "moving_mass" kg; a torsional fit's in N m, rad, rad and
    kg m^2), the set it belongs to (None: the fit's), value, standard error and Wald 95 % interval, whether the data determine it, and its
    effect: {free parameter: how far the estimate would move if the nuisance were held at zero}."""
    name: str
    set: Optional[int]
    value: float
    standard_error: float
    lower_95: float
    upper_95: float
    identified: bool
    effect: dict


def _figure_attribute(result, holder: str, name: str) -> np.ndarray:
    """result.<holder>[name] for attribute access to a result's figures (AttributeError else)."""
    figures = result.__dict__.get(holder)
    if figures is not None and name in figures:
        return figures[name]
    raise AttributeError(name)


@dataclass
class LoopAnalysisResult:
    """AnalyzeLoops' answer: per-cycle figures as numpy arrays (one value per complete cycle).

    figures: every figure of CycleFigures (docs/analysis.md), also read as attributes:
    first_sample, lower_reversal, last_sample (sample indices), start_time (s, NaN without
    time), force_amplitude Q* (N), force_offset (N), dissipated_energy Ed (J), half_opening
    delta_0 (m), system_free_ratio C (NaN when delta_0 is not above displacement_resolution or
    the cycle's round-off), normal_force P (N, NaN if unknown), friction_coefficient,
    energy_friction_coefficient (NaN as C, or without P), displacement_amplitude delta* (m),
    energy_ratio A, sliding_ratio B, secant_stiffness, stiffness_increasing,
    stiffness_decreasing (N/m).
    contact: the contact's own figures from u - C_t F_x (displacement_amplitude, energy_ratio,
    sliding_ratio, secant_stiffness, stiffness_increasing, stiffness_decreasing), or None without
    rig_compliance. flags: closure_error, not_closed, asymmetry, asymmetric, hook_ratio, hooked.
    regime ("sticking", "partial_slip", "gross_slip") and onset_system_free_ratio (the scene's C
    at the onset of gross slip): with a scene, else None. torsional: the record was torsional
    (twist, twisting_moment): every figure is then in rad and N m (force_amplitude M*,
    half_opening and displacement_amplitude in rad, stiffnesses in N m/rad), its
    friction_coefficient and energy_friction_coefficient are NaN (M*/P is a length), and with a
    scene full_slip_moment (N m, the scene's at each cycle's normal force) takes the place of
    onset_system_free_ratio (None otherwise). reversals: the sample indices of every
    reversal; reversal_threshold: the one used (m). measures: figure name -> "contact" (the
    same whatever the rig) or "contact+rig" (biased by the rig), "contact.*" for the contact
    figures. friction_drift: the relative change of mu (or Q*) across the run, friction_drifts
    whether it exceeds the tolerance. raw: the AnalyzeLoopsResponse as received.
    """
    figures: Figures
    contact: Optional[Figures]
    flags: Figures
    regime: Optional[np.ndarray]
    onset_system_free_ratio: Optional[np.ndarray]
    full_slip_moment: Optional[np.ndarray]
    torsional: bool
    reversals: np.ndarray
    reversal_threshold: float
    measures: dict
    friction_drift: float
    friction_drifts: bool
    raw: an.AnalyzeLoopsResponse = dataclasses.field(repr=False)

    def __getattr__(self, name: str):
        return _figure_attribute(self, "figures", name)

    def __len__(self) -> int:
        """The number of complete cycles."""
        return len(self.raw.cycles)

    @classmethod
    def of(cls, response: an.AnalyzeLoopsResponse,
           torsional: bool = False) -> "LoopAnalysisResult":
        """The result of a response; torsional: the request's record was (twist,
        twisting_moment), which the response does not repeat."""
        cycles = response.cycles
        classified = any(c.regime != an.REGIME_UNSPECIFIED for c in cycles)
        figures = figures_of(cycles, an.CycleFigures,
                             skip=("regime", "onset_system_free_ratio", "full_slip_moment"))
        contact = (figures_of([c.contact for c in cycles], an.ContactFigures)
                   if cycles and all(c.HasField("contact") for c in cycles) else None)
        flags = figures_of([c.flags for c in cycles], an.LoopFlags)
        regime = onset = slip = None
        if classified:
            regime = _array([c.regime for c in cycles],
                            an.CycleFigures.DESCRIPTOR.fields_by_name["regime"])
            if torsional:
                slip = np.array([c.full_slip_moment for c in cycles])
            else:
                onset = np.array([c.onset_system_free_ratio for c in cycles])
        measures = {name: _MEASURES.get(value, _enum_name(an.Measures.DESCRIPTOR, value))
                    for name, value in sorted(response.measures.items())}
        return cls(figures, contact, flags, regime, onset, slip, bool(torsional),
                   np.array(response.reversals, dtype=np.int64), response.reversal_threshold,
                   measures, response.friction_drift, response.friction_drifts, response)


@dataclass
class LoopFitResult:
    """FitLoops' result. names: the free parameters in the request's order ("friction",
    "effective_modulus", "profile_scale", "rig_compliance", "displacement_offset"); value,
    standard_error, lower_95, upper_95 (float64) and identified (bool): numpy arrays in that order
    (units: see Estimate); result["friction"] gives one parameter's Estimate, values a dict of
    the values. correlation: the (p, p) correlation matrix; residual_rms (N) over `residuals`
    counted samples; iterations, converged; condition_number and weakest_combination (relative
    parameter changes the data constrain least); all_identified: the overall verdict, notes
    why not; fitted_scene: the request's scene with the estimates (mdr.v1.Scene);
    guessed_rig_compliance and its standard error (m/N): the practitioners' guess from sets at two
    or more loads, else None; the error is None with two loads too (no residual is left).
    interval: how each interval was obtained ("wald", "half_cycle_sandwich"). adequate: the model
    explains every set to its noise and no declared load contradicts its column (all_identified
    requires it). sets: every SetFit figure as an array over the sets (displacement_noise,
    force_noise, normal_force_noise, reduced_chi_square, structure_p_value, misfit,
    load_mismatch, gross_slip, ...: docs/analysis.md, "Model adequacy"). nuisances: a
    NuisanceFit per fitted nuisance. reduced_chi_square over every set; parameters: the fitted
    coordinates, turning points and nuisances included. models: with include_models, per set
    Figures of actuator_path, normal_force, contact_force and predicted_force (one per sample),
    else None. raw: the mdr.v1.FitResult as received."""
    names: tuple
    value: np.ndarray
    standard_error: np.ndarray
    lower_95: np.ndarray
    upper_95: np.ndarray
    identified: np.ndarray
    correlation: np.ndarray
    residual_rms: float
    residuals: int
    iterations: int
    converged: bool
    condition_number: float
    weakest_combination: np.ndarray
    all_identified: bool
    notes: list
    fitted_scene: scene_pb2.Scene
    guessed_rig_compliance: Optional[float]
    guessed_rig_compliance_error: Optional[float]
    interval: tuple
    adequate: bool
    sets: Figures
    nuisances: list
    reduced_chi_square: float
    parameters: int
    models: Optional[list] = dataclasses.field(repr=False)
    raw: an.FitResult = dataclasses.field(repr=False)

    @property
    def values(self) -> dict:
        """{name: fitted value}."""
        return dict(zip(self.names, self.value.tolist()))

    def __getitem__(self, name: str) -> Estimate:
        if name not in self.names:
            raise KeyError(f"{name!r} was not free; free: {', '.join(self.names)}")
        k = self.names.index(name)
        return Estimate(float(self.value[k]), float(self.standard_error[k]),
                        float(self.lower_95[k]), float(self.upper_95[k]),
                        bool(self.identified[k]))

    @classmethod
    def of(cls, result: an.FitResult) -> "LoopFitResult":
        estimates = result.estimates
        names = tuple(_PARAMETER_NAMES.get(e.parameter, str(e.parameter)) for e in estimates)
        p = len(estimates)
        guessed = result.HasField("guessed_rig_compliance")
        return cls(
            names, np.array([e.value for e in estimates]),
            np.array([e.standard_error for e in estimates]),
            np.array([e.lower_95 for e in estimates]), np.array([e.upper_95 for e in estimates]),
            np.array([e.identified for e in estimates], dtype=bool),
            np.array(result.correlation, dtype=np.float64).reshape(p, p),
            result.residual_rms, result.residuals, result.iterations, result.converged,
            result.condition_number, np.array(result.weakest_combination), result.identified,
            list(result.notes), result.fitted_scene,
            result.guessed_rig_compliance if guessed else None,
            result.guessed_rig_compliance_error
            if result.HasField("guessed_rig_compliance_error") else None,
            tuple(_enum_name(an.IntervalMethod.DESCRIPTOR, e.interval) for e in estimates),
            result.adequate, figures_of(result.sets, an.SetFit),
            [NuisanceFit(_enum_name(an.Nuisance.DESCRIPTOR, n.nuisance),
                         n.set if n.HasField("set") else None, n.value, n.standard_error,
                         n.lower_95, n.upper_95, n.identified, dict(zip(names, n.effect)))
             for n in result.nuisances],
            result.reduced_chi_square, result.parameters,
            [Figures({f.name: np.array(getattr(m, f.name), dtype=np.float64)
                      for f in an.SetModel.DESCRIPTOR.fields})
             for m in result.models] if result.models else None,
            result)


def progress_caller(progress: Optional[Callable], request: an.FitLoopsRequest) -> Callable:
    """The FitProgress handler calling progress(iteration, residual_rms in N, {name: value})."""
    names = [_PARAMETER_NAMES.get(f.parameter, str(f.parameter)) for f in request.free]

    def handle(message: an.FitProgress) -> None:
        if progress is not None:
            progress(message.iteration, message.residual_rms,
                     dict(zip(names, message.values)))
    return handle


@dataclass
class FrettingMapResult:
    """FrettingMap's answer over L normal forces and M relative amplitudes.

    loops: every LoopFigures field as an (L, M) array, also read as attributes (normal_force,
    force_amplitude Q*, dissipated_energy Ed (J per cycle), half_opening, contact_amplitude,
    actuator_amplitude (m), energy_ratio, sliding_ratio (as measured through the rig),
    contact_energy_ratio, contact_sliding_ratio, system_free_ratio, secant_stiffness (N/m),
    damping_ratio); regime: (L, M) strings ("partial_slip", "gross_slip"); onset: the same
    fields as (L,) arrays at each force's onset of gross slip; normal_forces (N) and
    relative_amplitudes: the request's; raw: the FrettingMapResponse.
    """
    normal_forces: np.ndarray
    relative_amplitudes: np.ndarray
    loops: Figures
    regime: np.ndarray
    onset: Figures
    raw: an.FrettingMapResponse = dataclasses.field(repr=False)

    def __getattr__(self, name: str):
        return _figure_attribute(self, "loops", name)

    @classmethod
    def of(cls, request: an.FrettingMapRequest,
           response: an.FrettingMapResponse) -> "FrettingMapResult":
        shape = (len(response.loads), len(request.relative_amplitudes))
        loops = [loop for load in response.loads for loop in load.loops]
        if len(loops) != shape[0] * shape[1]:
            raise ValueError(f"FrettingMapResponse holds {len(loops)} loops for {shape[0]} "
                             f"loads x {shape[1]} amplitudes")
        regime_field = an.FrettingMapResponse.Load.DESCRIPTOR.fields_by_name["regimes"]
        regime = _array([r for load in response.loads for r in load.regimes],
                        regime_field).reshape(shape)
        return cls(np.array(request.normal_forces), np.array(request.relative_amplitudes),
                   figures_of(loops, an.LoopFigures, shape), regime,
                   figures_of([load.onset for load in response.loads], an.LoopFigures),
                   response)


@dataclass
class BackboneResult:
    """Backbone's answer: loops, every LoopFigures field as an array over the amplitudes, also
    read as attributes (secant_stiffness Q*/delta* in N/m, damping_ratio Ed/(2 pi Q* delta*),
    force_amplitude Q* in N, actuator_amplitude delta* in m ...; a torsional scene's M* in N m,
    twists in rad, N m/rad); amplitudes and kind: the request's ("force": N or N m,
    "actuator_displacement": m or rad); raw: the BackboneResponse."""
    amplitudes: np.ndarray
    kind: str
    loops: Figures
    raw: an.BackboneResponse = dataclasses.field(repr=False)

    def __getattr__(self, name: str):
        return _figure_attribute(self, "loops", name)

    @classmethod
    def of(cls, request: an.BackboneRequest, response: an.BackboneResponse) -> "BackboneResult":
        kind = _enum_name(an.BackboneRequest.AmplitudeKind.DESCRIPTOR, request.kind)
        return cls(np.array(request.amplitudes), kind,
                   figures_of(response.loops, an.LoopFigures), response)


class AnalysisCalls(abc.ABC):
    """The analysis of measured loops (docs/analysis.md): stateless, SI units, numpy arrays. One
    set of methods for both clients: a server's (Client: the RPCs) and the in-process one
    (libmdr_c's mdr_analysis_run, the same operations). A client provides _analyze(method,
    request) -> response and _fit(request, on_progress, timeout) -> FitResult."""

    @abc.abstractmethod
    def _analyze(self, method: str, request):
        """The response of AnalyzeLoops, FrettingMap or Backbone to request."""

    @abc.abstractmethod
    def _fit(self, request: an.FitLoopsRequest, on_progress: Callable,
             timeout: Optional[float]) -> an.FitResult:
        """The FitResult of request; on_progress(FitProgress) while the fit runs."""

    def analyze_loops(self, displacement=None, tangential_force=None, normal_force=None,
                      time=None, *, twist=None, twisting_moment=None,
                      scene: Optional[SceneLike] = None, rig_compliance: Optional[float] = None,
                      reversal_threshold: float = 0.0, displacement_resolution: float = 0.0,
                      closure_tolerance: Optional[float] = None,
                      asymmetry_tolerance: Optional[float] = None,
                      hook_tolerance: Optional[float] = None,
                      drift_tolerance: Optional[float] = None) -> LoopAnalysisResult:
        """The figures of every complete cycle of a run (AnalyzeLoops).

        displacement u (m) and tangential_force F_x (N): one value per sample (sequences or numpy
        arrays); or a torsional record (a ball twisted on a flat), twist phi (rad) and
        twisting_moment M (N m) as keywords instead: every figure keeps its definition with phi
        for u and M for F_x (result.torsional). normal_force F_N (N): one value per sample, or one
        number for a constant load that was not measured; time t (s): one per sample, strictly
        increasing. scene (a Scene, dict or scene file): classifies each cycle against the
        scene's onset of gross slip at the cycle's normal force (which must then be given); a
        torsional record's scene has torsion and classifies against its full-slip moment
        (result.full_slip_moment). rig_compliance C_t (m/N; torsional: the shaft's, rad/(N m)):
        adds the contact's own figures. reversal_threshold (m, rad; 0: 5 % of the median
        peak-to-peak displacement), displacement_resolution (m, rad: narrower loops stick, their
        C is NaN), the flag tolerances (None: the service's defaults). The service's checks name
        the field (MdrError, field "samples.displacement[12]", "samples.twist" for a record of
        both pairs, "scene.torsion" for a scene of the other kind)."""
        request = analyze_request(
            displacement, tangential_force, normal_force, time, twist=twist,
            twisting_moment=twisting_moment, scene=scene,
            rig_compliance=rig_compliance, reversal_threshold=reversal_threshold,
            displacement_resolution=displacement_resolution,
            closure_tolerance=closure_tolerance, asymmetry_tolerance=asymmetry_tolerance,
            hook_tolerance=hook_tolerance, drift_tolerance=drift_tolerance)
        torsional = len(request.samples.twist) > 0 or len(request.samples.twisting_moment) > 0
        return LoopAnalysisResult.of(self._analyze("AnalyzeLoops", request), torsional)

    def fit_loops(self, scene: SceneLike, sets, free, *, burn_in_reversals: Optional[int] = None,
                  reversal_threshold: float = 0.0, max_iterations: int = 0, nuisances=(),
                  displacement_noise: Optional[float] = None,
                  force_noise: Optional[float] = None, include_models: bool = False,
                  progress=None, timeout: Optional[float] = None) -> LoopFitResult:
        """Fits free parameters of a single-contact scene to measured loops (FitLoops) by
        replaying each set's actuator path through the exact engine with the scene's rig.

        sets: 1 to 64 loop sets, each (displacement in m, tangential_force in N, normal_force
        in N[, time in s]) or a dict with those keys: normal_force one number (the set's constant
        load) or an array (the measured normal force, replayed as measured; a dict's
        declared_normal_force is then checked against it). A scene with torsion makes the fit
        torsional: each set is then (twist in rad, twisting_moment in N m, normal_force[, time])
        or a dict with the keys twist and twisting_moment, replayed through the exact torsional
        memory at its constant normal force (a column's mean) behind the shaft's compliance
        (scene.torsion.rig_compliance). free: {"friction": {"lower": 0.1, "upper": 1,
        "initial": 0.4}, "rig_compliance": {...}, ...} (initial optional: the scene's value), or
        a list of such dicts with a "parameter" key; names: friction, effective_modulus (Pa),
        profile_scale (m), rig_compliance (m/N; torsional: rad/(N m)), displacement_offset (m;
        torsional: rad), torsional_modulus (G_t in Pa, torsional fits; the fitted scene's
        torsion carries it and the shaft).
        burn_in_reversals: residuals count from this reversal of each set on (None: 2);
        reversal_threshold in m (0: automatic); max_iterations (0: 200). nuisances: any of
        "force_offset", "displacement_drift" (per set) and "moving_mass" (needs time); every
        set's displacement offset and turning points are fitted always. displacement_noise (m)
        and force_noise (N): the sensors' noise where known (None: estimated from each set).
        include_models: return each set's model sample by sample (result.models). progress: called as
        progress(iteration, residual_rms in N, {name: value}) while the fit runs (a server sends
        the latest iteration whenever it can, so iterations may be skipped; in process every
        iteration is reported). timeout: seconds for the whole fit (default: the client's; in
        process: none, else checked after each iteration)."""
        request = fit_request(scene, sets, free, burn_in_reversals=burn_in_reversals,
                              reversal_threshold=reversal_threshold,
                              max_iterations=max_iterations, nuisances=nuisances,
                              displacement_noise=displacement_noise,
                              force_noise=force_noise, include_models=include_models)
        on_progress = progress_caller(progress, request)
        return LoopFitResult.of(self._fit(request, on_progress, timeout))

    def fretting_map(self, scene: SceneLike, normal_forces, relative_amplitudes
                     ) -> FrettingMapResult:
        """The exact steady loops of a single-contact scene (with its rig) at 1 to 100 normal
        forces (N) and 1 to 200 actuator amplitudes relative to the onset of gross slip at each
        force (in (0, 100]), each a sequence, an array or one number: (loads, amplitudes)
        arrays and each force's onset (FrettingMap)."""
        request = fretting_map_request(scene, normal_forces, relative_amplitudes)
        return FrettingMapResult.of(request, self._analyze("FrettingMap", request))

    def backbone(self, scene: SceneLike, normal_force: float, amplitudes,
                 kind: str = "force") -> BackboneResult:
        """Secant stiffness and damping ratio of the exact steady loops against amplitude at one
        normal force in N (Backbone). kind: "force" (amplitudes Q* in N, in (0, mu F_N]) or
        "actuator_displacement" (amplitudes in m, > 0); 1 to 1000 amplitudes. A scene with
        torsion gives the torsional backbone: "force" amplitudes are M* in N m (below the
        full-slip moment), "actuator_displacement" ones the twist in rad through the shaft
        (scene.torsion.rig_compliance); the loops' figures are in rad and N m."""
        request = backbone_request(scene, normal_force, amplitudes, kind)
        return BackboneResult.of(request, self._analyze("Backbone", request))
