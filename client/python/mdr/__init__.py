"""Python client of mdrd, the reference service for tangential contact under arbitrary loading
histories (Method of Dimensionality Reduction).

    import mdr
    with mdr.Client.embedded() as client:                # or mdr.Client("host:50051")
        with client.session("examples/hertz_cattaneo_mindlin.json") as s:
            s.apply({"normal_force": 100})
            result = s.apply([{"tangential_force": f} for f in (5, 10, 15)])
            print(result.tangential_displacement)          # numpy array, one value per step

Many contacts (an interface or a contact list in one session):

    scene = mdr.interface_scene(H1, "contact_list", heights=np.zeros(3))
    with client.session(scene) as s:
        s.apply(mdr.contact_step(depth_increment=[1e-6, 2e-6, 3e-6]))   # one value per contact
        q = s.query(["interface.totals"])                                 # q.interface.totals

Measured friction loops of a test rig (docs/analysis.md; SI units, numpy arrays in and out):

    r = client.analyze_loops(u, f_x, normal_force=100, scene=scene, rig_compliance=2e-8)
    r.force_amplitude, r.dissipated_energy, r.contact.secant_stiffness, r.regime  # per cycle
    r.measures["energy_ratio"]                                                    # "contact+rig"
    fit = client.fit_loops(scene, [(u1, f1, 50), (u2, f2, 200)],
                           {"friction": {"lower": 0.05, "upper": 1},
                            "rig_compliance": {"lower": 1e-9, "upper": 1e-7}},
                           progress=lambda iteration, rms, values: print(iteration, rms))
    fit["friction"].value, fit.lower_95, fit.correlation, fit.fitted_scene
    m = client.fretting_map(scene, [50, 100, 200], [0.5, 1.5])   # m.regime: (3, 2) strings
    b = client.backbone(scene, 100, np.linspace(1, 30, 30))      # b.damping_ratio over Q* (N)

A torsional record (a ball twisted on a flat; rad and N m) and a scene with "torsion":

    r = client.analyze_loops(twist=phi, twisting_moment=m, normal_force=100, scene=twisted)
    r.force_amplitude, r.full_slip_moment, r.regime                # M* and M_slip in N m
    fit = client.fit_loops(twisted, [(phi1, m1, 50), (phi2, m2, 200)],
                           {"friction": {...}, "torsional_modulus": {...},
                            "rig_compliance": {...}})               # the shaft in rad/(N m)

The generated API modules are mdr.v1.*_pb2 (messages) and mdr.v1.contact_service_pb2_grpc.
"""
from .analysis import (FIT_PARAMETERS, NUISANCES, BackboneResult, Estimate, Figures,
                       FrettingMapResult, LoopAnalysisResult, LoopFitResult, NuisanceFit)
from .client import Client, Session
from .embedded import EmbeddedServer, find_mdrd
from .errors import MdrError
from .messages import (ApplyResult, InterfaceResult, InterfaceTotals, QueryResult,
                       contact_step, interface_scene, load_scene_file, to_scene, to_step,
                       to_steps)

__all__ = ["Client", "Session", "EmbeddedServer", "find_mdrd", "MdrError", "ApplyResult",
           "InterfaceResult", "InterfaceTotals", "QueryResult", "contact_step",
           "interface_scene", "load_scene_file", "to_scene", "to_step", "to_steps",
           "FIT_PARAMETERS", "NUISANCES", "BackboneResult", "Estimate", "Figures",
           "FrettingMapResult", "LoopAnalysisResult", "LoopFitResult", "NuisanceFit"]
