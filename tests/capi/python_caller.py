"""Python on libmdr_c through ctypes, without gRPC: prints what service_reference.cc writes for
the service (reference.txt), which the test compares byte for byte.

    python_caller.py LIBMDR_C REFERENCE_DIR SCENE_FILE

The contact is created from the YAML scene file's text (the first pass) and, after the history,
restored from the service's snapshot (snapshot.pb) to repeat the second part.
"""
import ctypes
import struct
import sys

RESTORE_AT = 100
MDR_OK, MDR_OUT_OF_RANGE, MDR_ROUTE_BOTH = 0, 11, 1


class State(ctypes.Structure):
    """mdr_state of mdr.h."""
    _fields_ = [(name, ctypes.c_double) for name in (
        "depth", "tangential_displacement", "contact_radius", "normal_force",
        "tangential_force", "dissipated_energy", "friction_limit", "actuator_displacement",
        "actuator_depth", "last_step_dissipation")] + [
        ("applied_steps", ctypes.c_uint64), ("memory_vertices", ctypes.c_uint64)]


def load(path):
    lib = ctypes.CDLL(path)
    handle, size = ctypes.c_void_p, ctypes.c_size_t
    dbl_p = ctypes.POINTER(ctypes.c_double)
    signatures = {
        "mdr_version": [],
        "mdr_contact_create_from_text": [ctypes.c_char_p, ctypes.c_char_p,
                                         ctypes.POINTER(handle)],
        "mdr_contact_restore": [ctypes.c_char_p, size, ctypes.POINTER(handle)],
        "mdr_contact_step": [handle, ctypes.c_int, ctypes.c_double, ctypes.c_int,
                             ctypes.c_double, ctypes.c_void_p],
        "mdr_contact_state": [handle, ctypes.POINTER(State)],
        "mdr_contact_stiffness": [handle, dbl_p, dbl_p],
        "mdr_contact_jager_weights": [handle, dbl_p, dbl_p, dbl_p, size,
                                      ctypes.POINTER(size), dbl_p],
        "mdr_contact_tractions": [handle, dbl_p, size, ctypes.c_int, dbl_p, dbl_p, dbl_p, dbl_p,
                                  size],
        "mdr_contact_slip_intervals": [handle, dbl_p, dbl_p, ctypes.POINTER(ctypes.c_int32),
                                       size, ctypes.POINTER(size)],
    }
    for name, arguments in signatures.items():
        function = getattr(lib, name)
        function.argtypes = arguments
        function.restype = ctypes.c_int
    lib.mdr_contact_destroy.argtypes = [handle]
    lib.mdr_contact_destroy.restype = None
    lib.mdr_last_error_message.restype = ctypes.c_char_p
    lib.mdr_last_error_field.restype = ctypes.c_char_p
    return lib


def hexd(value):
    return "%016X" % struct.unpack("<Q", struct.pack("<d", value))[0]


def from_hex(text):
    return struct.unpack("<d", struct.pack("<Q", int(text, 16)))[0]


class Caller:
    def __init__(self, lib):
        self.lib = lib
        self.contact = ctypes.c_void_p()
        self.lines = []

    def check(self, status, what):
        if status != MDR_OK:
            raise RuntimeError("%s: %s (field %s)" % (
                what, self.lib.mdr_last_error_message().decode(),
                self.lib.mdr_last_error_field().decode()))

    def state(self):
        state = State()
        self.check(self.lib.mdr_contact_state(self.contact, ctypes.byref(state)), "state")
        return state

    def run(self, steps):
        for normal_control, normal_value, tangential_control, tangential_value in steps:
            self.check(self.lib.mdr_contact_step(self.contact, normal_control, normal_value,
                                                 tangential_control, tangential_value, None),
                       "step")
            s = self.state()
            self.lines.append("S " + " ".join(hexd(v) for v in (
                s.depth, s.tangential_displacement, s.contact_radius, s.normal_force,
                s.tangential_force, s.dissipated_energy)))

    def sized(self, function, *arrays_of):
        """Calls function(contact, arrays..., capacity, &count) twice: size, then values."""
        count = ctypes.c_size_t()
        status = function(self.contact, *[None] * len(arrays_of), 0, ctypes.byref(count))
        if status not in (MDR_OK, MDR_OUT_OF_RANGE):
            self.check(status, function.__name__)
        arrays = [(kind * max(count.value, 1))() for kind in arrays_of]
        self.check(function(self.contact, *arrays, count.value, ctypes.byref(count)),
                   function.__name__)
        return arrays, count.value

    def finals(self):
        lib, dbl = self.lib, ctypes.c_double
        positive, negative = dbl(), dbl()
        self.check(lib.mdr_contact_stiffness(self.contact, positive, negative), "stiffness")
        self.lines.append("K %s %s" % (hexd(positive.value), hexd(negative.value)))
        edge = dbl()
        weights = lambda c, a, b, w, cap, n: lib.mdr_contact_jager_weights(c, a, b, w, cap, n,
                                                                           ctypes.byref(edge))
        weights.__name__ = "jager_weights"
        (r_begin, r_end, weight), n = self.sized(weights, dbl, dbl, dbl)
        self.lines.append("J %d %s" % (n, hexd(edge.value)))
        for i in range(n):
            self.lines.append("W %s %s %s" % (hexd(r_begin[i]), hexd(r_end[i]), hexd(weight[i])))
        a = self.state().contact_radius
        radii = (dbl * 8)(*[a * k / 8 for k in range(8)])
        tau, tau_error, p, p_error = [(dbl * 8)() for _ in range(4)]
        self.check(lib.mdr_contact_tractions(self.contact, radii, 8, MDR_ROUTE_BOTH, tau,
                                             tau_error, p, p_error, 8), "tractions")
        for k in range(8):
            self.lines.append("T " + " ".join(hexd(v) for v in (tau[k], tau_error[k], p[k],
                                                                p_error[k])))
        (s_begin, s_end, direction), n = self.sized(lib.mdr_contact_slip_intervals, dbl, dbl,
                                                    ctypes.c_int32)
        self.lines.append("L %d" % n)
        for i in range(n):
            self.lines.append("I %s %s %d" % (hexd(s_begin[i]), hexd(s_end[i]), direction[i]))


def main():
    lib_path, reference_dir, scene_path = sys.argv[1:4]
    lib = load(lib_path)
    if lib.mdr_version() != 1:
        sys.exit("libmdr_c: interface version %d, not 1" % lib.mdr_version())
    with open(reference_dir + "/history.txt") as f:
        steps = [(int(n), from_hex(nv), int(t), from_hex(tv))
                 for n, nv, t, tv in (line.split() for line in f if line.strip())]
    caller = Caller(lib)
    with open(scene_path, "rb") as f:
        scene = f.read()
    caller.check(lib.mdr_contact_create_from_text(scene, scene_path.encode(),
                                                  ctypes.byref(caller.contact)), "create")
    caller.run(steps)
    lib.mdr_contact_destroy(caller.contact)
    with open(reference_dir + "/snapshot.pb", "rb") as f:
        snapshot = f.read()
    caller.check(lib.mdr_contact_restore(snapshot, len(snapshot), ctypes.byref(caller.contact)),
                 "restore")
    caller.run(steps[RESTORE_AT:])
    caller.finals()
    lib.mdr_contact_destroy(caller.contact)
    sys.stdout.write("\n".join(caller.lines) + "\n")


if __name__ == "__main__":
    main()
