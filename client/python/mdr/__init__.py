"""Python client of mdrd, the reference service for tangential contact under arbitrary loading
histories (Method of Dimensionality Reduction).

    import mdr
    with mdr.Client.embedded() as client:                # or mdr.Client("host:50051")
        with client.session("examples/hertz_cattaneo_mindlin.json") as s:
            s.apply({"normal_force": 100})
            result = s.apply([{"tangential_force": f} for f in (5, 10, 15)])
            print(result.tangential_displacement)          # numpy array, one value per step

The generated API modules are mdr.v1.*_pb2 (messages) and mdr.v1.contact_service_pb2_grpc.
"""
from .client import Client, Session
from .embedded import EmbeddedServer, find_mdrd
from .errors import MdrError
from .messages import (ApplyResult, QueryResult, load_scene_file, to_scene, to_step,
                       to_steps)

__all__ = ["Client", "Session", "EmbeddedServer", "find_mdrd", "MdrError", "ApplyResult",
           "QueryResult", "load_scene_file", "to_scene", "to_step", "to_steps"]
