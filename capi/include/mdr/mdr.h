/* The C interface of the MDR contact engine (libmdr_c): tangential and torsional contacts
 * in-process, with no server, for rig controllers, simulation codes in C, Fortran and Python,
 * MATLAB and LabVIEW. docs/capi.md describes the contract, the allocation and timing guarantees and
 * the callers.
 *
 * The contact is the service's: a scene is the proto's mdr.v1.Scene (serialized bytes, or a
 * YAML/JSON scene file as mdrctl reads it), a step is the proto's Step, and a snapshot is the
 * proto's SessionSnapshot, so a state moves between this library and the service (ExportSession
 * / ImportSession) and continues bit for bit. A scene of one contact is an mdr_contact; a scene
 * with an interface (scene.interface: a shared motion or a contact list of many contacts,
 * docs/interfaces.md) is an mdr_interface; a scene with scene.torsion (a twist about the
 * contact's axis, docs/physics.md "Torsion about the contact's axis") is an mdr_torsion.
 *
 * Conventions of every function:
 * - The return value is an mdr_status: MDR_OK (0) or an error code. On an error nothing changed
 *   (no handle, no state, no output array beyond the documented *count) and the calling thread's
 *   last error (mdr_last_error_code/_message/_field) names the argument or the scene field and
 *   the allowed range. A successful call leaves the last error as it was (like errno).
 * - Nothing throws across this interface; every C++ exception inside becomes MDR_INTERNAL (or
 *   MDR_RESOURCE_EXHAUSTED when memory ran out).
 * - Arrays are the caller's: a function writing values takes the array's capacity in elements
 *   and writes the number of values to *count (also when the capacity is too small, so the
 *   caller learns the size it needs: then MDR_OUT_OF_RANGE names the capacity argument).
 * - A handle is used by one thread at a time (no locking inside); different handles are
 *   independent. The last error is per thread.
 * - Units are SI: m, N, Pa, J; angles in rad, moments in N m.
 */
#ifndef MDR_MDR_H_
#define MDR_MDR_H_

#include <stddef.h>
#include <stdint.h>

/* The library is built with hidden visibility; only the functions marked MDR_API are exported. */
#if defined(MDR_C_BUILDING)
#define MDR_API __attribute__((visibility("default")))
#else
#define MDR_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* The version of this interface. It changes only when a function's signature or a struct's
 * layout changes incompatibly; additions keep it. Compare with mdr_version() at run time. */
#define MDR_C_API_VERSION 1
/* The revision within that version: it counts additions (functions, enum values, structs). A
 * caller that needs revision R checks mdr_api_revision() >= R. Revision 2: the tangential
 * controls numbered 0..3 (4..6 still accepted), mdr_api_revision, mdr_struct_size, the analysis
 * (mdr_analysis_run) and mdr_buffer. Revision 3: torsional contacts (mdr_torsion, its functions,
 * mdr_twist_control, mdr_torsional_state and MDR_STRUCT_TORSIONAL_STATE). Revision 4: the
 * harmonic-balance element (mdr_element and its functions). */
#define MDR_C_API_REVISION 4

/* Status codes: the numbers of the gRPC status codes the service answers with. */
typedef enum mdr_status {
  MDR_OK = 0,
  MDR_CANCELLED = 1,
  MDR_INVALID_ARGUMENT = 3, /* an argument or a scene field is out of its range */
  MDR_DEADLINE_EXCEEDED = 4,
  MDR_NOT_FOUND = 5,
  MDR_FAILED_PRECONDITION = 9, /* valid, but not from this state (|F_x| > mu F_N, grid method) */
  MDR_RESOURCE_EXHAUSTED = 8,  /* a limit (memory vertices, grid reach) or memory ran out */
  MDR_OUT_OF_RANGE = 11,       /* a caller's array is too small (the field names its capacity) */
  MDR_UNIMPLEMENTED = 12,      /* not available through this library */
  MDR_INTERNAL = 13,
  MDR_DATA_LOSS = 15
} mdr_status;

/* How each channel of a step is driven: 0..3 for each channel, so that a LabVIEW ring or a
 * MATLAB index maps onto them directly. HOLD leaves the channel where it is (the value must be
 * 0). Increments are relative to the current state. The tangential values 4, 5 and 6 of revision
 * 1 (the proto Step's field numbers) are still accepted, meaning 1, 2 and 3. */
typedef enum mdr_normal_control {
  MDR_NORMAL_HOLD = 0,
  MDR_NORMAL_DEPTH = 1,           /* target depth delta in m, finite */
  MDR_NORMAL_DEPTH_INCREMENT = 2, /* change of delta in m, finite */
  MDR_NORMAL_FORCE = 3            /* target F_N in N, finite and >= 0 */
} mdr_normal_control;

typedef enum mdr_tangential_control {
  MDR_TANGENTIAL_HOLD = 0,
  MDR_TANGENTIAL_DISPLACEMENT = 1,           /* target ux in m, finite */
  MDR_TANGENTIAL_DISPLACEMENT_INCREMENT = 2, /* change of ux in m, finite */
  MDR_TANGENTIAL_FORCE = 3                   /* target F_x in N, |F_x| <= mu F_N at the end */
} mdr_tangential_control;

/* The twist of a torsional contact (mdr_torsion_step) about the contact's axis. */
typedef enum mdr_twist_control {
  MDR_TWIST_HOLD = 0,
  MDR_TWIST_ANGLE = 1,           /* target twist phi in rad, finite */
  MDR_TWIST_ANGLE_INCREMENT = 2, /* change of phi in rad, finite */
  MDR_TWIST_MOMENT = 3           /* target moment M_z in N m, |M_z| < the full-slip moment */
} mdr_twist_control;

/* Routes of the surface tractions (the proto's TractionRoute). */
typedef enum mdr_traction_route {
  MDR_ROUTE_BOTH = 1, /* both; the value is the Jäger one, the error their difference */
  MDR_ROUTE_ABEL = 2, /* inverse MDR transform by quadrature */
  MDR_ROUTE_JAGER = 3 /* superposition of frictionless pressures (closed form) */
} mdr_traction_route;

/* The state after the last step: the proto's ContactState. Stable layout: 10 doubles then 2
 * uint64_t, 96 bytes, no padding (a Fortran bind(C) type, a ctypes Structure, a LabVIEW cluster
 * of 10 DBL and 2 U64 all match it). */
typedef struct mdr_state {
  double depth;                   /* delta in m (<= 0: no contact) */
  double tangential_displacement; /* ux in m */
  double contact_radius;          /* a in m */
  double normal_force;            /* F_N in N */
  double tangential_force;        /* F_x in N */
  double dissipated_energy;       /* J since creation (0 without scene.options.track_energy) */
  double friction_limit;          /* mu F_N in N */
  double actuator_displacement;   /* ux + C_t F_x in m (ux without a rig) */
  double actuator_depth;          /* delta + C_n F_N in m (delta without a rig) */
  double last_step_dissipation;   /* J dissipated by the last step */
  uint64_t applied_steps;         /* steps applied since creation (carried by snapshots) */
  uint64_t memory_vertices;       /* vertices of the exact memory (0 for the grid method) */
} mdr_state;

/* What the last step did: the proto's StepReport. Stable layout: int32, 4 bytes padding
 * (explicit), 2 doubles; 24 bytes. */
typedef struct mdr_step_report {
  int32_t substeps;  /* exact linear sub-steps used (1 for a straight step) */
  int32_t reserved;  /* 0 */
  double path_error; /* a curved path's estimated relative error, memory or energy */
  double dissipated; /* J dissipated by the step (0 when energy is not tracked) */
} mdr_step_report;

/* The state of a torsional contact after the last step: the proto's ContactState of a torsional
 * session. Stable layout: 9 doubles then 2 uint64_t, 88 bytes, no padding (applied_steps at byte
 * 72; a Fortran bind(C) type, a ctypes Structure, a LabVIEW cluster of 9 DBL and 2 U64). */
typedef struct mdr_torsional_state {
  double depth;                 /* delta in m (<= 0: no contact) */
  double contact_radius;        /* a in m */
  double normal_force;          /* F_N in N */
  double twist;                 /* phi in rad */
  double twisting_moment;       /* M_z in N m */
  double full_slip_moment;      /* the supremum of |M_z| at this load in N m (Hertz: 3 pi mu F_N
                                   a / 16) */
  double dissipated_energy;     /* J since creation (always tracked) */
  double last_step_dissipation; /* J dissipated by the last step */
  double friction_limit;        /* mu F_N in N */
  uint64_t applied_steps;       /* steps applied since creation (carried by snapshots) */
  uint64_t memory_pieces;       /* pieces of the torsional memory (the service's memory_vertices) */
} mdr_torsional_state;

/* An opaque contact: its scene's configuration and its state. */
typedef struct mdr_contact mdr_contact;

/* MDR_C_API_VERSION of the loaded library. */
MDR_API int mdr_version(void);
/* MDR_C_API_REVISION of the loaded library (since revision 2; a library of revision 1 lacks the
 * symbol, which dlsym reports as missing). */
MDR_API int mdr_api_revision(void);

/* The structs whose layout is part of the interface, for mdr_struct_size. */
typedef enum mdr_struct_id {
  MDR_STRUCT_STATE = 1,          /* mdr_state */
  MDR_STRUCT_STEP_REPORT = 2,    /* mdr_step_report */
  MDR_STRUCT_TORSIONAL_STATE = 3 /* mdr_torsional_state (since revision 3) */
} mdr_struct_id;
/* The size in bytes of a struct as the loaded library lays it out (0 for an unknown id): a
 * caller that declares the struct itself (LabVIEW's cluster, a ctypes Structure, a dlopen
 * caller) compares it with its own size before the first call that fills one. */
MDR_API size_t mdr_struct_size(int id);
/* Nonzero when the loaded library lays out this header's structs as this header does (a library
 * before revision 3 has no mdr_torsional_state: 0 then). */
#define MDR_LAYOUT_MATCHES()                                                    \
  (mdr_version() == MDR_C_API_VERSION &&                                        \
   mdr_struct_size(MDR_STRUCT_STATE) == sizeof(struct mdr_state) &&             \
   mdr_struct_size(MDR_STRUCT_STEP_REPORT) == sizeof(struct mdr_step_report) && \
   mdr_struct_size(MDR_STRUCT_TORSIONAL_STATE) == sizeof(struct mdr_torsional_state))
/* The library's release, e.g. "0.1.0" (static storage). */
MDR_API const char* mdr_version_string(void);

/* The calling thread's last error: its code (MDR_OK before any error), its message (UTF-8,
 * "" before any error) and the argument or scene field it names ("scene.sphere.radius",
 * "normal_value", "capacity"; "" when none). The strings stay valid until the thread's next
 * failing call. */
MDR_API int mdr_last_error_code(void);
MDR_API const char* mdr_last_error_message(void);
MDR_API const char* mdr_last_error_field(void);

/* Creates a contact from a serialized mdr.v1.Scene (size bytes at scene; scene may be NULL only
 * when size is 0, which is an empty and therefore invalid scene). The scene is validated as the
 * service's CreateSession does (errors name "scene.<field>"); options left unset take the
 * service's defaults. *out receives the new handle (NULL on error); release it with
 * mdr_contact_destroy. */
MDR_API int mdr_contact_create(const void* scene, size_t size, mdr_contact** out);

/* Creates a contact from the scene of a scene file as mdrctl reads it: YAML or JSON text of an
 * mdr.v1.SceneFile (NUL-terminated UTF-8; its path and outputs are not used). name stands for the
 * file in error messages (NULL: "scene"). Parse errors name the line and the field. */
MDR_API int mdr_contact_create_from_text(const char* text, const char* name, mdr_contact** out);

/* Creates a contact from a serialized mdr.v1.SessionSnapshot, as the service's ImportSession
 * does (version 1; a single contact: an interface's snapshot is mdr_interface_restore's): it
 * continues bit for bit like the exported session. Errors name "snapshot.<field>". The create
 * functions refuse an interface scene (INVALID_ARGUMENT naming scene.interface) and a torsional
 * one (naming scene.torsion: it is an mdr_torsion's). */
MDR_API int mdr_contact_restore(const void* snapshot, size_t size, mdr_contact** out);

/* Releases a contact (NULL: nothing happens). */
MDR_API void mdr_contact_destroy(mdr_contact* contact);

/* Applies one step, atomically: on error the contact is unchanged. The path semantics are the
 * proto Step's (docs/engine.md): both channels move linearly in a common parameter; a force
 * channel changing together with the other one is a curved path of adaptive sub-steps. Errors
 * name normal_control, normal_value, tangential_control, tangential_value or a scene limit.
 * report may be NULL. Once warmed up, a step of a bounded history allocates nothing (docs/capi.md,
 * "Allocation"). */
MDR_API int mdr_contact_step(mdr_contact* contact, int normal_control, double normal_value,
                             int tangential_control, double tangential_value,
                             mdr_step_report* report);

/* The state after the last step (allocation-free). */
MDR_API int mdr_contact_state(const mdr_contact* contact, mdr_state* out);

/* The incremental tangential stiffness dF_x/dux for a small further move in +x (*positive) and in
 * -x (*negative), in N/m (allocation-free). */
MDR_API int mdr_contact_stiffness(const mdr_contact* contact, double* positive, double* negative);

/* The radial intervals where springs slip: interval i is [r_begin[i], r_end[i]] in m, direction[i]
 * +1 at +mu kappa w, -1 at -mu kappa w. *count receives their number; the three arrays hold
 * capacity elements each (all may be NULL when capacity is 0, to ask for the count). */
MDR_API int mdr_contact_slip_intervals(const mdr_contact* contact, double* r_begin, double* r_end,
                                       int32_t* direction, size_t capacity, size_t* count);

/* The Jäger weights of the state (the service's jager_weights output): interval i has weight[i]
 * on (r_begin[i], r_end[i]) in m; *edge_weight is the flat punch's edge weight (0 otherwise; may
 * be NULL). Arrays and count as for mdr_contact_slip_intervals. FAILED_PRECONDITION for the grid
 * method, mu = 0, or a depth where mu kappa delta rounds to 0. */
MDR_API int mdr_contact_jager_weights(const mdr_contact* contact, double* r_begin, double* r_end,
                                      double* weight, size_t capacity, size_t* count,
                                      double* edge_weight);

/* The surface tractions at n radii (m, each finite and >= 0): tangential tau(r) and normal
 * pressure p(r) in Pa, with the error estimate of each (the service's tractions and pressure
 * outputs, by `route`). Each output array holds capacity elements (>= n); any of the four may be
 * NULL if not wanted. Values may be infinite (a flat punch edge), never NaN. tau needs the exact
 * method (FAILED_PRECONDITION for the grid method). */
MDR_API int mdr_contact_tractions(const mdr_contact* contact, const double* radii, size_t n,
                                  int route, double* tangential, double* tangential_error,
                                  double* normal, double* normal_error, size_t capacity);

/* The exact state as a serialized mdr.v1.SessionSnapshot (version 1; the scene with every option
 * as resolved, no limits, no source name), which the service's ImportSession and
 * mdr_contact_restore accept. *size receives its length in bytes; buffer holds capacity bytes
 * (NULL with capacity 0 asks for the size). */
MDR_API int mdr_contact_snapshot(const mdr_contact* contact, void* buffer, size_t capacity,
                                 size_t* size);

/* ---- Interfaces: many contacts in one handle (docs/interfaces.md) ---- */

/* An opaque interface: a shared motion of contacts at height offsets, or a contact list of
 * independent contacts (a discrete-element code's), as an interface session of the service. */
typedef struct mdr_interface mdr_interface;

/* Create, create from a scene file's text, restore from a SessionSnapshot and release an
 * interface: as the mdr_contact functions, for a scene with scene.interface (INVALID_ARGUMENT
 * naming scene.interface for a scene of one contact). The service's CreateSession and
 * ImportSession checks apply, its size check included. */
MDR_API int mdr_interface_create(const void* scene, size_t size, mdr_interface** out);
MDR_API int mdr_interface_create_from_text(const char* text, const char* name, mdr_interface** out);
MDR_API int mdr_interface_restore(const void* snapshot, size_t size, mdr_interface** out);
MDR_API void mdr_interface_destroy(mdr_interface* interface);

/* The number of contacts in *count. */
MDR_API int mdr_interface_size(const mdr_interface* interface, size_t* count);

/* Applies one step, atomically, as the service's Step of an interface session:
 * - a shared motion: the controls move the approach (depth), the total normal force, the common
 *   tangential displacement or the total tangential force; normal_values and tangential_values
 *   are NULL and n is 0;
 * - a contact list: a control chooses what the values of its channel mean for every contact
 *   (target depth, depth increment, target normal force; displacement, its increment, tangential
 *   force), its own value must be 0, and the channel's array holds one value per contact (n =
 *   mdr_interface_size); a HOLD channel passes NULL.
 * Errors name normal_control, normal_value, tangential_control, tangential_value,
 * normal_values[i], tangential_values[i] or n. */
MDR_API int mdr_interface_step(mdr_interface* interface, int normal_control, double normal_value,
                               int tangential_control, double tangential_value,
                               const double* normal_values, const double* tangential_values,
                               size_t n);

/* The interface's state as the service reports it: forces, energy and friction limit summed over
 * the contacts in contact order, depth and tangential_displacement the shared motion's (0 for a
 * contact list), contact_radius and last_step_dissipation 0, memory_vertices summed. */
MDR_API int mdr_interface_state(const mdr_interface* interface, mdr_state* out);

/* Every contact's own state, in contact order, into out[0..*count) (capacity records). */
MDR_API int mdr_interface_contact_states(const mdr_interface* interface, mdr_state* out,
                                         size_t capacity, size_t* count);

/* The exact state as a serialized mdr.v1.SessionSnapshot with snapshot.interface, as
 * mdr_contact_snapshot (the service's ImportSession accepts it). */
MDR_API int mdr_interface_snapshot(const mdr_interface* interface, void* buffer, size_t capacity,
                                   size_t* size);

/* ---- Torsion about the contact's axis (docs/physics.md "Torsion", docs/capi.md "Torsion") ---- */

/* An opaque torsional contact: a scene with scene.torsion, as a torsional session of the service
 * (the same construction, steps, outputs and snapshots: server/bridge torsion_session). */
typedef struct mdr_torsion mdr_torsion;

/* Create, create from a scene file's text, restore from a SessionSnapshot and release a
 * torsional contact: as the mdr_contact functions, for a scene with scene.torsion (a scene
 * without it is refused, INVALID_ARGUMENT naming scene.torsion or snapshot.scene.torsion). The
 * service's checks apply: a single contact (scene.interface unset), METHOD_EXACT, no rig,
 * friction > 0 and no flat punch, each naming its field. A restored contact continues bit for
 * bit like the exported session (ImportSession's checks of snapshot.torsion). */
MDR_API int mdr_torsion_create(const void* scene, size_t size, mdr_torsion** out);
MDR_API int mdr_torsion_create_from_text(const char* text, const char* name, mdr_torsion** out);
MDR_API int mdr_torsion_restore(const void* snapshot, size_t size, mdr_torsion** out);
MDR_API void mdr_torsion_destroy(mdr_torsion* torsion);

/* Applies one step, atomically (on error the contact is unchanged): the normal channel at fixed
 * twist or the twist at fixed normal load, each exact. One that moves both channels is refused
 * (INVALID_ARGUMENT naming twist_control; apply them as two steps). Both HOLD is an empty step
 * (counted). A moment target must stay below the full-slip moment (FAILED_PRECONDITION naming
 * twist_value); a load decrease that would leave springs on the bound of the larger contact is
 * FAILED_PRECONDITION naming normal_value; a memory beyond scene.options.max_memory_vertices
 * pieces is RESOURCE_EXHAUSTED. Errors name normal_control, normal_value, twist_control or
 * twist_value. report (may be NULL): substeps 1, path_error 0, dissipated the step's energy.
 * Once warmed up, a twist by angle or increment allocates nothing; a moment target and a load
 * change allocate (docs/capi.md, "Torsion"). */
MDR_API int mdr_torsion_step(mdr_torsion* torsion, int normal_control, double normal_value,
                             int twist_control, double twist_value, mdr_step_report* report);

/* The state after the last step (allocation-free). */
MDR_API int mdr_torsion_state(const mdr_torsion* torsion, mdr_torsional_state* out);

/* dM_z/dphi for a small further twist in +phi (*positive) and in -phi (*negative), in N m/rad;
 * 0 out of contact (allocation-free). */
MDR_API int mdr_torsion_stiffness(const mdr_torsion* torsion, double* positive, double* negative);

/* The annuli whose springs slip (lie on a bound of the current contact): interval i is
 * [r_begin[i], r_end[i]] in m, direction[i] +1 slipping in +phi, -1 in -phi, ordered by radius.
 * Arrays and count as for mdr_contact_slip_intervals. */
MDR_API int mdr_torsion_slip_intervals(const mdr_torsion* torsion, double* r_begin, double* r_end,
                                       int32_t* direction, size_t capacity, size_t* count);

/* The circumferential traction tau_phi(r) in Pa at n radii (m, each finite and >= 0; 0 at r = 0
 * and outside the contact), by the Abel route, and |its difference from the superposition
 * route| in Pa (the service's torsion.tractions: value and route_difference, a check of both
 * quadratures, not a bound of the error). Each output array holds capacity elements (>= n);
 * either may be NULL if not wanted. */
MDR_API int mdr_torsion_tractions(const mdr_torsion* torsion, const double* radii, size_t n,
                                  double* traction, double* route_difference, size_t capacity);

/* The elastic energy the springs hold, in J (allocation-free as mdr_torsion_state). */
MDR_API int mdr_torsion_stored_energy(const mdr_torsion* torsion, double* energy);

/* The exact state as a serialized mdr.v1.SessionSnapshot with snapshot.torsion, as
 * mdr_contact_snapshot (the service's ImportSession and mdr_torsion_restore accept it). */
MDR_API int mdr_torsion_snapshot(const mdr_torsion* torsion, void* buffer, size_t capacity,
                                 size_t* size);

/* ---- The harmonic-balance element (docs/dynamics.md) ---- */

/* An opaque contact element for harmonic balance: a single contact, or an interface's asperities
 * under a shared motion (scene.interface, KIND_SHARED_MOTION), pressed once to a constant normal
 * force at u = 0. */
typedef struct mdr_element mdr_element;

/* Creates an element from a serialized mdr.v1.Scene (or, _from_text, a scene file's text) pressed
 * to normal_force in N (> 0; an interface's total, its approach solved exactly). Errors name
 * "normal_force" or "scene.<field>" (a torsional scene, the grid method, a rig and a contact
 * list are refused). Release with mdr_element_destroy. */
MDR_API int mdr_element_create(const void* scene, size_t size, double normal_force,
                               mdr_element** out);
MDR_API int mdr_element_create_from_text(const char* text, const char* name, double normal_force,
                                         mdr_element** out);
MDR_API void mdr_element_destroy(mdr_element* element);

/* One alternating frequency-time evaluation: the tangential displacement's coefficients
 * u(tau) = U_0 + sum_h U_h^c cos(h tau) + U_h^s sin(h tau) for the harmonics given (increasing,
 * 0 first when present; count = 1 for harmonic 0 + 2 per other one, ordered [U_0, U_h1^c, U_h1^s,
 * ...]) to the steady contact force's coefficients in the same form (force: count values) and,
 * if jacobian is not NULL, dF_a/dU_b (count x count, row-major), exactly (the element is
 * rate-independent: dF/domega = 0). samples: time samples per period, a power of two in
 * [8, 65536] above twice the highest harmonic. dissipated_energy (may be NULL): J per period.
 * The element is unchanged: every call starts from the pressed state, and a refused call writes
 * nothing. Errors name element, coefficients (count), coefficients[i] (finite), harmonics,
 * harmonic_count (at most 32768), harmonics[k], samples, force, or displacement[j] for a time
 * sample beyond 1 m. */
MDR_API int mdr_element_aft(const mdr_element* element, const double* coefficients, size_t count,
                            const int32_t* harmonics, size_t harmonic_count, int32_t samples,
                            double* force, double* jacobian, double* dissipated_energy);

/* ---- The analysis of measured loops (docs/analysis.md, docs/capi.md "Analysis") ---- */

/* The service's analysis operations, in-process: the request and the response are the proto's
 * messages (analysis.proto), so that the validation, the limits and the error fields are the
 * service's ("samples.displacement", "sets[2].normal_force", "free[0].lower", ...). */
typedef enum mdr_analysis {
  MDR_ANALYZE_LOOPS = 1, /* AnalyzeLoopsRequest -> AnalyzeLoopsResponse */
  MDR_FIT_LOOPS = 2,     /* FitLoopsRequest -> FitResult (progress: FitProgress) */
  MDR_FRETTING_MAP = 3,  /* FrettingMapRequest -> FrettingMapResponse */
  MDR_BACKBONE = 4       /* BackboneRequest -> BackboneResponse */
} mdr_analysis;

/* How the request, the response and the progress messages are written. */
typedef enum mdr_encoding {
  MDR_ENCODING_PROTO = 0, /* the serialized message */
  MDR_ENCODING_JSON = 1   /* proto3 JSON (UTF-8; the proto's field names; NaN and infinities as
                             "NaN", "Infinity"), for MATLAB, Octave, LabVIEW and scripts */
} mdr_encoding;

/* Bytes the library owns: a response. mdr_buffer_data is followed by a NUL byte (a JSON
 * response is a C string); both accessors accept NULL (NULL, 0). */
typedef struct mdr_buffer mdr_buffer;
MDR_API const void* mdr_buffer_data(const mdr_buffer* buffer);
MDR_API size_t mdr_buffer_size(const mdr_buffer* buffer);
MDR_API void mdr_buffer_destroy(mdr_buffer* buffer);

/* Called on the calling thread after every iteration of a fit with a FitProgress message (size
 * bytes, in the request's encoding; valid during the call only). A non-zero return stops the fit:
 * mdr_analysis_run then returns MDR_CANCELLED naming "progress" and no response. */
typedef int (*mdr_progress_callback)(const void* progress, size_t size, void* user);

/* Runs one analysis on a request of size bytes in `encoding`. On success *response receives the
 * response (release it with mdr_buffer_destroy), with compute_seconds filled; on an error it is
 * NULL and the last error names the request's field, "request" (not a message of the type, or
 * not JSON), "analysis", "encoding" or "progress". progress and user may be NULL; progress is
 * called by MDR_FIT_LOOPS only. The work is bounded by the request's checked sizes (the
 * service's: analysis.proto); a fit is cancellable through progress. Allocates (the request, the
 * response, the work): call it outside a real-time loop. Handles of contacts are not involved;
 * any thread may call it. */
MDR_API int mdr_analysis_run(int analysis, int encoding, const void* request, size_t size,
                             mdr_progress_callback progress, void* user, mdr_buffer** response);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* MDR_MDR_H_ */
