/* The MEX gateway of the +mdr package (MATLAB and Octave) over libmdr_c (capi/include/mdr/mdr.h):
 * one function, mdr_mex(command, ...), that +mdr's classes and functions call; users call +mdr.
 * It builds with `mkoctfile --mex` (Octave) and `mex` (MATLAB); docs/matlab.md.
 *
 * Handles are uint64 scalars that this gateway has handed out: every call checks its argument
 * against the live ones (a cleared or forged handle is an error, never a crash), and the handles
 * still alive when the MEX file is cleared are released. Errors are MATLAB errors whose
 * identifier is mdr:<code> (mdr:invalidArgument, mdr:failedPrecondition, ...) and whose message
 * is libmdr_c's, which names the argument or the field.
 *
 * Commands (inputs after the command; outputs):
 *   'version'                                   -> [api_version, revision], release string
 *   'live'                                      -> the number of live handles (of both kinds)
 *   'create', text, name                        -> handle (scene file text: YAML or JSON)
 *   'restore', bytes (uint8)                    -> handle (a SessionSnapshot)
 *   'destroy', handle
 *   'step', handle, normal_control, normal_value, tangential_control, tangential_value
 *                                               -> [substeps, path_error, dissipated]
 *   'state', handle                             -> struct of mdr_state's fields
 *   'stiffness', handle                         -> [positive, negative] in N/m
 *   'slip_intervals', handle                    -> n-by-3 [r_begin, r_end, direction]
 *   'jager_weights', handle                     -> n-by-3 [r_begin, r_end, weight], edge weight
 *   'tractions', handle, radii, route           -> n-by-4 [tau, tau_error, p, p_error]
 *   'snapshot', handle                          -> uint8 row
 *   'element_create', text, name, normal_force  -> element handle (docs/dynamics.md)
 *   'element_aft', handle, U, harmonics, samples -> F (column), dF/dU, energy per period
 *   'element_destroy', handle
 *   'analysis', number, request_json [, progress_function]
 *                                               -> response JSON with its numbers replaced by
 *                                                  their indices, the numbers (ExactNumbers)
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mdr/mdr.h"
#include "mex.h"

/* ---- The live handles ---- */

/* What a handle points to: each kind has its own functions, and a handle of one kind given to
 * the other's command is refused. */
typedef enum { kContact, kElement } Kind;

typedef struct {
  void* pointer;
  Kind kind;
} Live;

typedef struct {
  Live* items;
  size_t count, capacity;
} Handles;

static Handles live = {NULL, 0, 0};

static void Release(Live item) {
  if (item.kind == kContact) {
    mdr_contact_destroy((mdr_contact*)item.pointer);
  } else {
    mdr_element_destroy((mdr_element*)item.pointer);
  }
}

static void ReleaseAll(void) {
  size_t i;
  for (i = 0; i < live.count; ++i) Release(live.items[i]);
  free(live.items);
  live.items = NULL;
  live.count = live.capacity = 0;
}

static void Remember(void* pointer, Kind kind) {
  const Live item = {pointer, kind};
  if (live.count == live.capacity) {
    const size_t capacity = live.capacity == 0 ? 16 : 2 * live.capacity;
    Live* items = (Live*)realloc(live.items, capacity * sizeof *items);
    if (items == NULL) {
      Release(item);
      mexErrMsgIdAndTxt("mdr:resourceExhausted", "out of memory for the handle table");
    }
    live.items = items;
    live.capacity = capacity;
  }
  live.items[live.count++] = item;
}

/* The index of a live handle of that kind, or (size_t)-1. */
static size_t Find(const void* pointer, Kind kind) {
  size_t i;
  for (i = 0; i < live.count; ++i) {
    if (live.items[i].pointer == pointer && live.items[i].kind == kind) return i;
  }
  return (size_t)-1;
}

static void Forget(size_t index) { live.items[index] = live.items[--live.count]; }

/* ---- Errors ---- */

static const char* Identifier(int code) {
  switch (code) {
    case MDR_CANCELLED:
      return "mdr:cancelled";
    case MDR_INVALID_ARGUMENT:
      return "mdr:invalidArgument";
    case MDR_DEADLINE_EXCEEDED:
      return "mdr:deadlineExceeded";
    case MDR_NOT_FOUND:
      return "mdr:notFound";
    case MDR_FAILED_PRECONDITION:
      return "mdr:failedPrecondition";
    case MDR_RESOURCE_EXHAUSTED:
      return "mdr:resourceExhausted";
    case MDR_OUT_OF_RANGE:
      return "mdr:outOfRange";
    case MDR_UNIMPLEMENTED:
      return "mdr:unimplemented";
    case MDR_DATA_LOSS:
      return "mdr:dataLoss";
    default:
      return "mdr:internal";
  }
}

/* A failed libmdr_c call as a MATLAB error (does not return). */
static void Check(int status) {
  if (status == MDR_OK) return;
  mexErrMsgIdAndTxt(Identifier(status), "%s", mdr_last_error_message());
}

static void Usage(const char* what) { mexErrMsgIdAndTxt("mdr:invalidArgument", "%s", what); }

/* ---- Arguments ---- */

static char* String(const mxArray* argument, const char* name) {
  char* text;
  if (!mxIsChar(argument)) {
    mexErrMsgIdAndTxt("mdr:invalidArgument", "%s: must be a character row", name);
  }
  text = mxArrayToString(argument);
  if (text == NULL) mexErrMsgIdAndTxt("mdr:invalidArgument", "%s: not a readable string", name);
  return text;
}

static double Scalar(const mxArray* argument, const char* name) {
  if (!mxIsDouble(argument) || mxIsComplex(argument) || mxGetNumberOfElements(argument) != 1) {
    mexErrMsgIdAndTxt("mdr:invalidArgument", "%s: must be a real double scalar", name);
  }
  return mxGetScalar(argument);
}

/* An integer control or number given as a double scalar. */
static int Integer(const mxArray* argument, const char* name) {
  const double value = Scalar(argument, name);
  if (!(value >= -2147483648.0 && value <= 2147483647.0) || value != (double)(int)value) {
    mexErrMsgIdAndTxt("mdr:invalidArgument", "%s: must be an integer, got %g", name, value);
  }
  return (int)value;
}

/* The live handle of that kind an argument holds (an error otherwise). */
static void* LiveHandle(const mxArray* argument, Kind kind) {
  void* pointer;
  if (!mxIsUint64(argument) || mxGetNumberOfElements(argument) != 1) {
    mexErrMsgIdAndTxt("mdr:invalidArgument", "handle: must be a uint64 scalar from mdr_mex");
  }
  pointer = (void*)(uintptr_t)(*(const uint64_t*)mxGetData(argument));
  if (Find(pointer, kind) == (size_t)-1) {
    mexErrMsgIdAndTxt("mdr:invalidArgument",
                      "handle: not a live %s (destroyed, or not made by this MEX file)",
                      kind == kContact ? "contact" : "element");
  }
  return pointer;
}

static mdr_contact* Handle(const mxArray* argument) {
  return (mdr_contact*)LiveHandle(argument, kContact);
}

static mxArray* HandleArray(void* pointer) {
  mxArray* array = mxCreateNumericMatrix(1, 1, mxUINT64_CLASS, mxREAL);
  *(uint64_t*)mxGetData(array) = (uint64_t)(uintptr_t)pointer;
  return array;
}

static void Arguments(int nrhs, int expected, const char* usage) {
  if (nrhs != expected) Usage(usage);
}

/* ---- Commands ---- */

static void Version(int nlhs, mxArray* plhs[]) {
  mxArray* versions = mxCreateDoubleMatrix(1, 2, mxREAL);
  mxGetPr(versions)[0] = mdr_version();
  mxGetPr(versions)[1] = mdr_api_revision();
  plhs[0] = versions;
  if (nlhs > 1) plhs[1] = mxCreateString(mdr_version_string());
}

static void Create(mxArray* plhs[], const mxArray* prhs[]) {
  char* text = String(prhs[1], "text");
  char* name = String(prhs[2], "name");
  mdr_contact* contact = NULL;
  const int status = mdr_contact_create_from_text(text, name, &contact);
  mxFree(text);
  mxFree(name);
  Check(status);
  Remember(contact, kContact);
  plhs[0] = HandleArray(contact);
}

static void Restore(mxArray* plhs[], const mxArray* prhs[]) {
  mdr_contact* contact = NULL;
  if (!mxIsUint8(prhs[1])) Usage("snapshot: must be a uint8 array");
  Check(mdr_contact_restore(mxGetData(prhs[1]), mxGetNumberOfElements(prhs[1]), &contact));
  Remember(contact, kContact);
  plhs[0] = HandleArray(contact);
}

static void Destroy(const mxArray* prhs[]) {
  mdr_contact* contact = Handle(prhs[1]);
  Forget(Find(contact, kContact));
  mdr_contact_destroy(contact);
}

static void Step(mxArray* plhs[], const mxArray* prhs[]) {
  mdr_contact* contact = Handle(prhs[1]);
  mdr_step_report report;
  double* out;
  Check(mdr_contact_step(contact, Integer(prhs[2], "normal_control"),
                         Scalar(prhs[3], "normal_value"), Integer(prhs[4], "tangential_control"),
                         Scalar(prhs[5], "tangential_value"), &report));
  plhs[0] = mxCreateDoubleMatrix(1, 3, mxREAL);
  out = mxGetPr(plhs[0]);
  out[0] = report.substeps;
  out[1] = report.path_error;
  out[2] = report.dissipated;
}

static void State(mxArray* plhs[], const mxArray* prhs[]) {
  static const char* kFields[] = {"depth",
                                  "tangential_displacement",
                                  "contact_radius",
                                  "normal_force",
                                  "tangential_force",
                                  "dissipated_energy",
                                  "friction_limit",
                                  "actuator_displacement",
                                  "actuator_depth",
                                  "last_step_dissipation",
                                  "applied_steps",
                                  "memory_vertices"};
  mdr_state s;
  int i;
  Check(mdr_contact_state(Handle(prhs[1]), &s));
  plhs[0] = mxCreateStructMatrix(1, 1, 12, kFields);
  {
    const double numbers[12] = {s.depth,
                                s.tangential_displacement,
                                s.contact_radius,
                                s.normal_force,
                                s.tangential_force,
                                s.dissipated_energy,
                                s.friction_limit,
                                s.actuator_displacement,
                                s.actuator_depth,
                                s.last_step_dissipation,
                                (double)s.applied_steps,
                                (double)s.memory_vertices};
    for (i = 0; i < 12; ++i) mxSetField(plhs[0], 0, kFields[i], mxCreateDoubleScalar(numbers[i]));
  }
}

static void Stiffness(mxArray* plhs[], const mxArray* prhs[]) {
  double positive = 0, negative = 0;
  Check(mdr_contact_stiffness(Handle(prhs[1]), &positive, &negative));
  plhs[0] = mxCreateDoubleMatrix(1, 2, mxREAL);
  mxGetPr(plhs[0])[0] = positive;
  mxGetPr(plhs[0])[1] = negative;
}

static void SlipIntervals(mxArray* plhs[], const mxArray* prhs[]) {
  const mdr_contact* contact = Handle(prhs[1]);
  size_t count = 0, i;
  double *begin, *end, *out;
  int32_t* direction;
  const int sizing = mdr_contact_slip_intervals(contact, NULL, NULL, NULL, 0, &count);
  if (sizing != MDR_OK && sizing != MDR_OUT_OF_RANGE) Check(sizing);
  begin = (double*)mxCalloc(count + 1, sizeof *begin);
  end = (double*)mxCalloc(count + 1, sizeof *end);
  direction = (int32_t*)mxCalloc(count + 1, sizeof *direction);
  Check(mdr_contact_slip_intervals(contact, begin, end, direction, count, &count));
  plhs[0] = mxCreateDoubleMatrix(count, 3, mxREAL);
  out = mxGetPr(plhs[0]);
  for (i = 0; i < count; ++i) {
    out[i] = begin[i];
    out[count + i] = end[i];
    out[2 * count + i] = direction[i];
  }
  mxFree(begin);
  mxFree(end);
  mxFree(direction);
}

static void JagerWeights(int nlhs, mxArray* plhs[], const mxArray* prhs[]) {
  const mdr_contact* contact = Handle(prhs[1]);
  size_t count = 0, i;
  double edge = 0;
  double *begin, *end, *weight, *out;
  const int sizing = mdr_contact_jager_weights(contact, NULL, NULL, NULL, 0, &count, NULL);
  if (sizing != MDR_OK && sizing != MDR_OUT_OF_RANGE) Check(sizing);
  begin = (double*)mxCalloc(count + 1, sizeof *begin);
  end = (double*)mxCalloc(count + 1, sizeof *end);
  weight = (double*)mxCalloc(count + 1, sizeof *weight);
  Check(mdr_contact_jager_weights(contact, begin, end, weight, count, &count, &edge));
  plhs[0] = mxCreateDoubleMatrix(count, 3, mxREAL);
  out = mxGetPr(plhs[0]);
  for (i = 0; i < count; ++i) {
    out[i] = begin[i];
    out[count + i] = end[i];
    out[2 * count + i] = weight[i];
  }
  if (nlhs > 1) plhs[1] = mxCreateDoubleScalar(edge);
  mxFree(begin);
  mxFree(end);
  mxFree(weight);
}

static void Tractions(mxArray* plhs[], const mxArray* prhs[]) {
  const mdr_contact* contact = Handle(prhs[1]);
  const int route = Integer(prhs[3], "route");
  size_t n;
  double* out;
  if (!mxIsDouble(prhs[2]) || mxIsComplex(prhs[2])) Usage("radii: must be a real double array");
  n = mxGetNumberOfElements(prhs[2]);
  plhs[0] = mxCreateDoubleMatrix(n, 4, mxREAL);
  out = mxGetPr(plhs[0]);
  Check(mdr_contact_tractions(contact, mxGetPr(prhs[2]), n, route, out, out + n, out + 2 * n,
                              out + 3 * n, n));
}

static void Snapshot(mxArray* plhs[], const mxArray* prhs[]) {
  const mdr_contact* contact = Handle(prhs[1]);
  size_t size = 0;
  const int sizing = mdr_contact_snapshot(contact, NULL, 0, &size);
  if (sizing != MDR_OK && sizing != MDR_OUT_OF_RANGE) Check(sizing);
  plhs[0] = mxCreateNumericMatrix(1, size, mxUINT8_CLASS, mxREAL);
  Check(mdr_contact_snapshot(contact, mxGetData(plhs[0]), size, &size));
}

/* A JSON text with its numbers taken out, exactly: every number outside a string is parsed with
 * strtod (correctly rounded) into *numbers and replaced by its index, 0-based. jsondecode reads
 * the small integer indices exactly, where its own parsing of a 17-digit double may be 1 ulp off;
 * mdr.internal.from_json puts the numbers back. */
static void ExactNumbers(const char* json, size_t size, mxArray** text, mxArray** numbers) {
  char* out = (char*)mxCalloc(size + 1, 1); /* an index is never longer than its number */
  double* values = (double*)mxCalloc(size / 2 + 1, sizeof *values);
  size_t count = 0, w = 0, r = 0;
  int in_string = 0;
  mxArray* array;
  while (r < size) {
    const char c = json[r];
    if (in_string) {
      out[w++] = c;
      ++r;
      if (c == '\\' && r < size) {
        out[w++] = json[r++];
      } else if (c == '"') {
        in_string = 0;
      }
    } else if (c == '"') {
      in_string = 1;
      out[w++] = c;
      ++r;
    } else if (c == '-' || (c >= '0' && c <= '9')) {
      char* end = NULL;
      char index[24];
      size_t length;
      values[count] = strtod(json + r, &end);
      length = (size_t)snprintf(index, sizeof index, "%lu", (unsigned long)count);
      ++count;
      memcpy(out + w, index, length);
      w += length;
      r = (size_t)(end - json) > r ? (size_t)(end - json) : r + 1;
    } else {
      out[w++] = c;
      ++r;
    }
  }
  out[w] = '\0';
  *text = mxCreateString(out);
  array = mxCreateDoubleMatrix(count, 1, mxREAL);
  if (count > 0) memcpy(mxGetPr(array), values, count * sizeof *values);
  *numbers = array;
  mxFree(out);
  mxFree(values);
}

/* The fit's progress into a MATLAB function: mdr.internal.call_progress(progress, json, numbers)
 * decodes it and calls progress(p), whose true stops the fit. An error inside it stops the fit too
 * and is raised after the call returns. */
typedef struct {
  const mxArray* function;
  int failed;
  char message[512]; /* the progress function's error */
} Progress;

static int CallProgress(const void* message, size_t size, void* user) {
  Progress* progress = (Progress*)user;
  mxArray *inputs[3], *output = NULL, *error;
  int stop = 0;
  inputs[0] = (mxArray*)progress->function;
  ExactNumbers((const char*)message, size, &inputs[1], &inputs[2]);
  /* A named function, not feval of a composed anonymous one: Octave 7's trap loses nested
   * anonymous calls. It decodes the message and calls the user's function. */
  error = mexCallMATLABWithTrap(1, &output, 3, inputs, "mdr.internal.call_progress");
  mxDestroyArray(inputs[1]);
  mxDestroyArray(inputs[2]);
  if (error != NULL) {
    mxArray* message = mxGetProperty(error, 0, "message");
    progress->failed = 1;
    progress->message[0] = '\0';
    if (message != NULL && mxIsChar(message)) {
      mxGetString(message, progress->message, sizeof progress->message);
    }
    if (message != NULL) mxDestroyArray(message);
    mxDestroyArray(error);
    return 1;
  }
  if (output != NULL && mxIsChar(output)) { /* the progress function's error message */
    progress->failed = 1;
    mxGetString(output, progress->message, sizeof progress->message);
    mxDestroyArray(output);
    return 1;
  }
  if (output != NULL) {
    stop = (mxIsLogical(output) || mxIsNumeric(output)) && mxGetNumberOfElements(output) == 1 &&
           mxGetScalar(output) != 0;
    mxDestroyArray(output);
  }
  return stop;
}

static void Analysis(int nrhs, mxArray* plhs[], const mxArray* prhs[]) {
  const int number = Integer(prhs[1], "analysis");
  char* request = String(prhs[2], "request");
  Progress progress = {NULL, 0, ""};
  mdr_buffer* response = NULL;
  int status;
  if (nrhs > 3) {
    if (!mxIsClass(prhs[3], "function_handle")) Usage("progress: must be a function handle");
    progress.function = prhs[3];
  }
  status = mdr_analysis_run(number, MDR_ENCODING_JSON, request, strlen(request),
                            progress.function != NULL ? CallProgress : NULL, &progress, &response);
  mxFree(request);
  if (progress.failed) {
    mexErrMsgIdAndTxt("mdr:progressFailed",
                      "the progress function raised an error, so the fit "
                      "stopped: %s",
                      progress.message);
  }
  Check(status);
  ExactNumbers((const char*)mdr_buffer_data(response), mdr_buffer_size(response), &plhs[0],
               &plhs[1]);
  mdr_buffer_destroy(response);
}

/* ---- The harmonic-balance element (docs/dynamics.md) ---- */

static void ElementCreate(mxArray* plhs[], const mxArray* prhs[]) {
  char* text = String(prhs[1], "text");
  char* name = String(prhs[2], "name");
  const double normal_force = Scalar(prhs[3], "normal_force");
  mdr_element* element = NULL;
  const int status = mdr_element_create_from_text(text, name, normal_force, &element);
  mxFree(text);
  mxFree(name);
  Check(status);
  Remember(element, kElement);
  plhs[0] = HandleArray(element);
}

static void ElementDestroy(const mxArray* prhs[]) {
  mdr_element* element = (mdr_element*)LiveHandle(prhs[1], kElement);
  Forget(Find(element, kElement));
  mdr_element_destroy(element);
}

/* [F, dF/dU, energy]: F a column like U; dF/dU count-by-count (MATLAB's column-major array is
 * the row-major result transposed), or empty when not asked for. */
static void ElementAft(int nlhs, mxArray* plhs[], const mxArray* prhs[]) {
  const mdr_element* element = (const mdr_element*)LiveHandle(prhs[1], kElement);
  const mxArray* u = prhs[2];
  const mxArray* h = prhs[3];
  const int samples = Integer(prhs[4], "samples");
  size_t count, harmonic_count, k;
  int32_t* harmonics;
  double energy = 0;
  double* jacobian = NULL;
  int status;
  if (!mxIsDouble(u) || mxIsComplex(u)) Usage("coefficients: must be a real double vector");
  if (!mxIsDouble(h) || mxIsComplex(h)) Usage("harmonics: must be a real double vector");
  count = mxGetNumberOfElements(u);
  harmonic_count = mxGetNumberOfElements(h);
  harmonics = (int32_t*)mxMalloc((harmonic_count > 0 ? harmonic_count : 1) * sizeof *harmonics);
  for (k = 0; k < harmonic_count; ++k) {
    const double value = mxGetPr(h)[k];
    if (!(value >= -1e9 && value <= 1e9) || value != (double)(int32_t)value) {
      mxFree(harmonics);
      mexErrMsgIdAndTxt("mdr:invalidArgument", "harmonics(%zu): must be an integer, got %g",
                        k + 1, value);
    }
    harmonics[k] = (int32_t)value;
  }
  plhs[0] = mxCreateDoubleMatrix(count, 1, mxREAL);
  if (nlhs > 1) {
    plhs[1] = mxCreateDoubleMatrix(count, count, mxREAL);
    jacobian = mxGetPr(plhs[1]);
  }
  status = mdr_element_aft(element, mxGetPr(u), count, harmonics, harmonic_count, samples,
                           mxGetPr(plhs[0]), jacobian, &energy);
  mxFree(harmonics);
  Check(status);
  if (jacobian != NULL) { /* row-major to column-major: transpose in place */
    size_t a, b;
    for (a = 0; a < count; ++a) {
      for (b = a + 1; b < count; ++b) {
        const double t = jacobian[a * count + b];
        jacobian[a * count + b] = jacobian[b * count + a];
        jacobian[b * count + a] = t;
      }
    }
  }
  if (nlhs > 2) plhs[2] = mxCreateDoubleScalar(energy);
}

void mexFunction(int nlhs, mxArray* plhs[], int nrhs, const mxArray* prhs[]) {
  char* command;
  static int registered = 0;
  if (!registered) {
    mexAtExit(ReleaseAll);
    registered = 1;
    if (!(mdr_version() == MDR_C_API_VERSION &&
          mdr_struct_size(MDR_STRUCT_STATE) == sizeof(mdr_state) &&
          mdr_struct_size(MDR_STRUCT_STEP_REPORT) == sizeof(mdr_step_report))) {
      mexErrMsgIdAndTxt("mdr:internal", "the loaded libmdr_c does not match mdr.h");
    }
  }
  if (nrhs < 1) Usage("usage: mdr_mex(command, ...); call the +mdr package instead");
  command = String(prhs[0], "command");
  if (strcmp(command, "version") == 0) {
    Version(nlhs, plhs);
  } else if (strcmp(command, "live") == 0) {
    plhs[0] = mxCreateDoubleScalar((double)live.count);
  } else if (strcmp(command, "create") == 0) {
    Arguments(nrhs, 3, "usage: mdr_mex('create', text, name)");
    Create(plhs, prhs);
  } else if (strcmp(command, "restore") == 0) {
    Arguments(nrhs, 2, "usage: mdr_mex('restore', snapshot)");
    Restore(plhs, prhs);
  } else if (strcmp(command, "destroy") == 0) {
    Arguments(nrhs, 2, "usage: mdr_mex('destroy', handle)");
    Destroy(prhs);
  } else if (strcmp(command, "step") == 0) {
    Arguments(nrhs, 6,
              "usage: mdr_mex('step', handle, normal_control, normal_value, "
              "tangential_control, tangential_value)");
    Step(plhs, prhs);
  } else if (strcmp(command, "state") == 0) {
    Arguments(nrhs, 2, "usage: mdr_mex('state', handle)");
    State(plhs, prhs);
  } else if (strcmp(command, "stiffness") == 0) {
    Arguments(nrhs, 2, "usage: mdr_mex('stiffness', handle)");
    Stiffness(plhs, prhs);
  } else if (strcmp(command, "slip_intervals") == 0) {
    Arguments(nrhs, 2, "usage: mdr_mex('slip_intervals', handle)");
    SlipIntervals(plhs, prhs);
  } else if (strcmp(command, "jager_weights") == 0) {
    Arguments(nrhs, 2, "usage: mdr_mex('jager_weights', handle)");
    JagerWeights(nlhs, plhs, prhs);
  } else if (strcmp(command, "tractions") == 0) {
    Arguments(nrhs, 4, "usage: mdr_mex('tractions', handle, radii, route)");
    Tractions(plhs, prhs);
  } else if (strcmp(command, "snapshot") == 0) {
    Arguments(nrhs, 2, "usage: mdr_mex('snapshot', handle)");
    Snapshot(plhs, prhs);
  } else if (strcmp(command, "element_create") == 0) {
    Arguments(nrhs, 4, "usage: mdr_mex('element_create', text, name, normal_force)");
    ElementCreate(plhs, prhs);
  } else if (strcmp(command, "element_aft") == 0) {
    Arguments(nrhs, 5, "usage: mdr_mex('element_aft', handle, coefficients, harmonics, samples)");
    ElementAft(nlhs, plhs, prhs);
  } else if (strcmp(command, "element_destroy") == 0) {
    Arguments(nrhs, 2, "usage: mdr_mex('element_destroy', handle)");
    ElementDestroy(prhs);
  } else if (strcmp(command, "analysis") == 0) {
    if (nrhs != 3 && nrhs != 4) Usage("usage: mdr_mex('analysis', number, request[, progress])");
    Analysis(nrhs, plhs, prhs);
  } else {
    mexErrMsgIdAndTxt("mdr:invalidArgument", "command: unknown, got '%s'", command);
  }
  mxFree(command);
}
