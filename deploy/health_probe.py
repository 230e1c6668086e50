#!/usr/bin/env python3
"""grpc.health.v1 probe for containers: exits 0 if the named service is SERVING.

Usage: health_probe.py [ADDRESS] [SERVICE]   (defaults: 127.0.0.1:50051, "readiness")
Encodes HealthCheckRequest by hand (field 1, the service name) so no generated stubs are needed;
Kubernetes uses its native gRPC probe instead (deploy/k8s/statefulset.yaml).
"""
import sys

import grpc

SERVING = 1


def check(address, service, timeout=2.0):
    name = service.encode()
    request = b"\x0a" + bytes([len(name)]) + name if name else b""
    with grpc.insecure_channel(address) as channel:
        call = channel.unary_unary("/grpc.health.v1.Health/Check")
        response = call(request, timeout=timeout)
    # HealthCheckResponse: field 1 (varint) status; absent means UNKNOWN (0).
    return response[1] if len(response) >= 2 and response[0] == 0x08 else 0


def main():
    address = sys.argv[1] if len(sys.argv) > 1 else "127.0.0.1:50051"
    service = sys.argv[2] if len(sys.argv) > 2 else "readiness"
    try:
        status = check(address, service)
    except grpc.RpcError as error:
        print(f"health_probe: {address} {service!r}: {error.code().name}", file=sys.stderr)
        return 1
    print(f"health_probe: {address} {service!r}: status {status}")
    return 0 if status == SERVING else 1


if __name__ == "__main__":
    sys.exit(main())
