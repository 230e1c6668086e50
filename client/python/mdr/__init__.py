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

The generated API modules are mdr.v1.*_pb2 (messages) and mdr.v1.contact_service_pb2_grpc.
"""
from .client import Client, Session
from .embedded import EmbeddedServer, find_mdrd
from .errors import MdrError
from .messages import (ApplyResult, InterfaceResult, InterfaceTotals, QueryResult,
                       contact_step, interface_scene, load_scene_file, to_scene, to_step,
                       to_steps)

__all__ = ["Client", "Session", "EmbeddedServer", "find_mdrd", "MdrError", "ApplyResult",
           "InterfaceResult", "InterfaceTotals", "QueryResult", "contact_step",
           "interface_scene", "load_scene_file", "to_scene", "to_step", "to_steps"]
