// libFuzzer target for libmdr_c's contact functions (capi/include/mdr/mdr.h), through the header
// alone: a scene from fuzzed bytes, or H1 from a scene file's text, or H1's snapshot with fuzzed
// bytes written over it; then fuzzed steps (any control number, any double, NaN and infinities
// included; no curved force paths, see Step) and queries with fuzzed sizes and null arrays. Checks:
// nothing crashes (ASan + UBSan); every error has a message, and INVALID_ARGUMENT and OUT_OF_RANGE
// name their field; a refused step leaves the state unchanged, bit for bit; an accepted step leaves
// finite forces; a too-small array is refused with the size needed; and every state reached
// round-trips through its snapshot (restore, snapshot again: the same bytes). Build and run:
// tests/fuzz/run.sh.
//
// Input: byte 0 chooses the contact's origin (mod 3: scene bytes, H1 text, H1 snapshot
// overwritten); for scene bytes the next two bytes give the scene's length; the rest drives
// steps and queries. A byte 0 of 0xF0 or more runs one analysis (mdr_analysis_run) instead: on
// fuzzed bytes in either encoding, or on a JSON request of fuzzed numbers and sizes, with a
// progress callback that may stop a fit; an error has no response and names its field. A byte 0
// from 0xE0 to 0xEF drives a torsional contact (mdr_torsion) instead, with the same origins (H1
// twisted, a piece limit of 16) and checks: steps of either channel or both (refused) with any
// control and value, a refused step leaves the snapshot's bytes, an accepted one a finite moment
// within the full-slip moment, every state round-trips, and each kind of scene is refused by the
// other kind's functions. A byte 0 from 0xD0 to 0xDF drives a harmonic-balance element
// (mdr_element: H1, a shared-motion interface or scene bytes, pressed to a fuzzed force) through
// fuzzed harmonics, sample counts and coefficients, and checks: an error names its field, an
// answer is finite, bounded by 4/pi mu F_N, and the same bits on a second call.
#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "mdr/mdr.h"

namespace {

constexpr char kH1Text[] =
    "scene:\n"
    "  sphere: {radius: 0.01}\n"
    "  elastic_pair: {youngs_modulus_1: 210e9, poisson_ratio_1: 0.3, youngs_modulus_2: 210e9,\n"
    "                 poisson_ratio_2: 0.3}\n"
    "  friction: 0.3\n"
    "  options: {track_energy: true}\n";

void Fail(const char* what) {
  std::fprintf(stderr, "invariant: %s (last error %d: %s [%s])\n", what, mdr_last_error_code(),
               mdr_last_error_message(), mdr_last_error_field());
  std::abort();
}

// Every error explains itself; argument errors name the argument.
void CheckError(int status) {
  if (status == MDR_OK) return;
  if (mdr_last_error_code() != status) Fail("the last error's code differs from the status");
  if (std::strlen(mdr_last_error_message()) == 0) Fail("an error without a message");
  if ((status == MDR_INVALID_ARGUMENT || status == MDR_OUT_OF_RANGE) &&
      std::strlen(mdr_last_error_field()) == 0) {
    Fail("an argument error without a field");
  }
}

std::vector<unsigned char> Snapshot(const mdr_contact* contact) {
  size_t size = 0;
  if (mdr_contact_snapshot(contact, nullptr, 0, &size) != MDR_OUT_OF_RANGE && size != 0) {
    Fail("asking for the snapshot's size");
  }
  std::vector<unsigned char> bytes(size);
  if (mdr_contact_snapshot(contact, bytes.data(), bytes.size(), &size) != MDR_OK) {
    Fail("a snapshot into a buffer of the size asked for");
  }
  bytes.resize(size);
  return bytes;
}

void CheckRoundTrip(const mdr_contact* contact) {
  const std::vector<unsigned char> bytes = Snapshot(contact);
  mdr_contact* restored = nullptr;
  if (mdr_contact_restore(bytes.data(), bytes.size(), &restored) != MDR_OK) {
    Fail("a reached state does not restore");
  }
  if (Snapshot(restored) != bytes) Fail("a restored state's snapshot differs");
  mdr_contact_destroy(restored);
}

mdr_contact* H1() {
  mdr_contact* contact = nullptr;
  if (mdr_contact_create_from_text(kH1Text, "h1", &contact) != MDR_OK) Fail("H1 from text");
  return contact;
}

mdr_contact* Origin(FuzzedDataProvider& input) {
  mdr_contact* contact = nullptr;
  int status = MDR_OK;
  switch (input.ConsumeIntegral<std::uint8_t>() % 3) {
    case 0: {
      const std::vector<unsigned char> scene =
          input.ConsumeBytes<unsigned char>(input.ConsumeIntegral<std::uint16_t>());
      status = mdr_contact_create(scene.data(), scene.size(), &contact);
      break;
    }
    case 1:
      contact = H1();
      break;
    default: {
      mdr_contact* h1 = H1();
      if (mdr_contact_step(h1, MDR_NORMAL_DEPTH, 3e-6, MDR_TANGENTIAL_DISPLACEMENT, 2e-7,
                           nullptr) != MDR_OK) {
        Fail("H1's first step");
      }
      std::vector<unsigned char> bytes = Snapshot(h1);
      mdr_contact_destroy(h1);
      const int writes = input.ConsumeIntegralInRange(0, 8);
      for (int i = 0; i < writes && !bytes.empty(); ++i) {
        bytes[input.ConsumeIntegralInRange<size_t>(0, bytes.size() - 1)] =
            input.ConsumeIntegral<unsigned char>();
      }
      status = mdr_contact_restore(bytes.data(), bytes.size(), &contact);
    }
  }
  CheckError(status);
  if ((contact == nullptr) == (status == MDR_OK)) Fail("a handle with an error, or none without");
  return contact;
}

double AnyDouble(FuzzedDataProvider& input) {
  switch (input.ConsumeIntegral<std::uint8_t>() % 8) {
    case 0:
      return std::nan("");
    case 1:
      return input.ConsumeBool() ? INFINITY : -INFINITY;
    case 2:
      return input.ConsumeFloatingPoint<double>();
    default:  // the scales of a contact: micrometres and newtons
      return input.ConsumeFloatingPointInRange<double>(-1e-5, 1e-5) *
             (input.ConsumeBool() ? 1 : 1e7);
  }
}

void Step(mdr_contact* contact, FuzzedDataProvider& input) {
  static constexpr int kNormal[] = {MDR_NORMAL_HOLD, MDR_NORMAL_DEPTH, MDR_NORMAL_DEPTH_INCREMENT,
                                    MDR_NORMAL_FORCE, 42};
  static constexpr int kTangential[] = {MDR_TANGENTIAL_HOLD,
                                        MDR_TANGENTIAL_DISPLACEMENT,
                                        MDR_TANGENTIAL_DISPLACEMENT_INCREMENT,
                                        MDR_TANGENTIAL_FORCE,
                                        -1,
                                        5 /* revision 1's displacement increment */};
  const int normal = input.PickValueInArray(kNormal);
  const double normal_value =
      normal == MDR_NORMAL_HOLD && input.ConsumeBool() ? 0 : AnyDouble(input);
  int tangential = input.PickValueInArray(kTangential);
  // A force target with the other channel moving is a curved path of adaptive sub-steps, whose
  // cost grows with the path's curvature (minutes under ASan for extreme values); the engine and
  // request fuzzers cover it. Here the other channel holds.
  if ((normal == MDR_NORMAL_FORCE) != (tangential == MDR_TANGENTIAL_FORCE) &&
      normal != MDR_NORMAL_HOLD && tangential != MDR_TANGENTIAL_HOLD) {
    tangential = MDR_TANGENTIAL_HOLD;
  }
  const double tangential_value =
      tangential == MDR_TANGENTIAL_HOLD && input.ConsumeBool() ? 0 : AnyDouble(input);
  mdr_state before{}, after{};
  if (mdr_contact_state(contact, &before) != MDR_OK) Fail("state");
  mdr_step_report report{};
  const int status = mdr_contact_step(contact, normal, normal_value, tangential, tangential_value,
                                      input.ConsumeBool() ? &report : nullptr);
  CheckError(status);
  if (mdr_contact_state(contact, &after) != MDR_OK) Fail("state");
  if (std::getenv("MDR_CAPI_FUZZ_TRACE") != nullptr) {  // to reproduce a finding as a test
    std::fprintf(stderr, "step(%d, %.17g, %d, %.17g) -> %d: delta %.17g ux %.17g F_x %.17g\n",
                 normal, normal_value, tangential, tangential_value, status, after.depth,
                 after.tangential_displacement, after.tangential_force);
  }
  if (status != MDR_OK) {
    if (std::memcmp(&before, &after, sizeof before) != 0) Fail("a refused step changed the state");
    return;
  }
  if (!std::isfinite(after.normal_force) || !std::isfinite(after.tangential_force)) {
    Fail("an accepted step left a force that is not finite");
  }
}

void Query(const mdr_contact* contact, FuzzedDataProvider& input) {
  const size_t capacity = input.ConsumeIntegralInRange<size_t>(0, 16);
  std::vector<double> a(capacity), b(capacity), c(capacity), d(capacity);
  std::vector<std::int32_t> direction(capacity);
  size_t count = 0;
  const bool null_arrays = capacity == 0 && input.ConsumeBool();
  double* first = null_arrays ? nullptr : a.data();
  switch (input.ConsumeIntegral<std::uint8_t>() % 4) {
    case 0: {
      const int status =
          mdr_contact_slip_intervals(contact, first, b.data(), direction.data(), capacity, &count);
      CheckError(status);
      if (status == MDR_OUT_OF_RANGE && count <= capacity) Fail("refused though it fitted");
      break;
    }
    case 1: {
      double edge = 0;
      const int status =
          mdr_contact_jager_weights(contact, first, b.data(), c.data(), capacity, &count, &edge);
      CheckError(status);
      if (status == MDR_OUT_OF_RANGE && count <= capacity) Fail("refused though it fitted");
      break;
    }
    case 2: {
      std::vector<double> radii(input.ConsumeIntegralInRange<size_t>(0, capacity + 1));
      for (double& r : radii) r = input.ConsumeBool() ? AnyDouble(input) : 1e-4 * r + 1e-5;
      CheckError(mdr_contact_tractions(contact, radii.data(), radii.size(),
                                       input.ConsumeIntegralInRange(0, 4), a.data(), b.data(),
                                       c.data(), d.data(), capacity));
      break;
    }
    default: {
      double positive = 0, negative = 0;
      CheckError(mdr_contact_stiffness(contact, &positive, &negative));
    }
  }
}

// ---- Torsional contacts (mdr_torsion) ----

constexpr char kH1TorsionText[] =
    "scene:\n"
    "  sphere: {radius: 0.01}\n"
    "  elastic_pair: {youngs_modulus_1: 210e9, poisson_ratio_1: 0.3, youngs_modulus_2: 210e9,\n"
    "                 poisson_ratio_2: 0.3}\n"
    "  friction: 0.3\n"
    "  options: {max_memory_vertices: 16}\n"
    "  torsion: {}\n";

std::vector<unsigned char> Snapshot(const mdr_torsion* torsion) {
  size_t size = 0;
  if (mdr_torsion_snapshot(torsion, nullptr, 0, &size) != MDR_OUT_OF_RANGE && size != 0) {
    Fail("asking for the torsion snapshot's size");
  }
  std::vector<unsigned char> bytes(size);
  if (mdr_torsion_snapshot(torsion, bytes.data(), bytes.size(), &size) != MDR_OK) {
    Fail("a torsion snapshot into a buffer of the size asked for");
  }
  bytes.resize(size);
  return bytes;
}

void CheckRoundTrip(const mdr_torsion* torsion) {
  const std::vector<unsigned char> bytes = Snapshot(torsion);
  mdr_torsion* restored = nullptr;
  if (mdr_torsion_restore(bytes.data(), bytes.size(), &restored) != MDR_OK) {
    Fail("a reached torsional state does not restore");
  }
  if (Snapshot(restored) != bytes) Fail("a restored torsional state's snapshot differs");
  mdr_torsion_destroy(restored);
}

mdr_torsion* TwistedH1() {
  mdr_torsion* torsion = nullptr;
  if (mdr_torsion_create_from_text(kH1TorsionText, "h1", &torsion) != MDR_OK) {
    Fail("twisted H1 from text");
  }
  return torsion;
}

// Each kind of scene is the other kind's error, naming scene.torsion.
void CheckKindsRefused() {
  mdr_contact* contact = nullptr;
  mdr_torsion* torsion = nullptr;
  if (mdr_contact_create_from_text(kH1TorsionText, "h1", &contact) != MDR_INVALID_ARGUMENT ||
      std::strcmp(mdr_last_error_field(), "scene.torsion") != 0 || contact != nullptr) {
    Fail("a contact of a torsional scene");
  }
  if (mdr_torsion_create_from_text(kH1Text, "h1", &torsion) != MDR_INVALID_ARGUMENT ||
      std::strcmp(mdr_last_error_field(), "scene.torsion") != 0 || torsion != nullptr) {
    Fail("a torsional contact of a tangential scene");
  }
}

mdr_torsion* TorsionOrigin(FuzzedDataProvider& input) {
  mdr_torsion* torsion = nullptr;
  int status = MDR_OK;
  switch (input.ConsumeIntegral<std::uint8_t>() % 3) {
    case 0: {
      const std::vector<unsigned char> scene =
          input.ConsumeBytes<unsigned char>(input.ConsumeIntegral<std::uint16_t>());
      status = mdr_torsion_create(scene.data(), scene.size(), &torsion);
      break;
    }
    case 1:
      CheckKindsRefused();
      torsion = TwistedH1();
      break;
    default: {
      mdr_torsion* h1 = TwistedH1();
      if (mdr_torsion_step(h1, MDR_NORMAL_FORCE, 100, MDR_TWIST_HOLD, 0, nullptr) != MDR_OK ||
          mdr_torsion_step(h1, MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE, 2e-3, nullptr) != MDR_OK ||
          mdr_torsion_step(h1, MDR_NORMAL_HOLD, 0, MDR_TWIST_ANGLE, 1e-3, nullptr) != MDR_OK) {
        Fail("twisted H1's first steps");
      }
      std::vector<unsigned char> bytes = Snapshot(h1);
      mdr_torsion_destroy(h1);
      const int writes = input.ConsumeIntegralInRange(0, 8);
      for (int i = 0; i < writes && !bytes.empty(); ++i) {
        bytes[input.ConsumeIntegralInRange<size_t>(0, bytes.size() - 1)] =
            input.ConsumeIntegral<unsigned char>();
      }
      status = mdr_torsion_restore(bytes.data(), bytes.size(), &torsion);
    }
  }
  CheckError(status);
  if ((torsion == nullptr) == (status == MDR_OK)) Fail("a handle with an error, or none without");
  return torsion;
}

// A twist or a moment of a twisted contact (mrad, mN m), or any double.
double AnyTwistValue(FuzzedDataProvider& input) {
  if (input.ConsumeIntegralInRange(0, 3) == 0) return AnyDouble(input);
  return input.ConsumeFloatingPointInRange<double>(-5e-3, 5e-3);
}

void TorsionStep(mdr_torsion* torsion, FuzzedDataProvider& input) {
  static constexpr int kNormal[] = {MDR_NORMAL_HOLD, MDR_NORMAL_DEPTH, MDR_NORMAL_DEPTH_INCREMENT,
                                    MDR_NORMAL_FORCE, 42};
  static constexpr int kTwist[] = {
      MDR_TWIST_HOLD, MDR_TWIST_ANGLE, MDR_TWIST_ANGLE_INCREMENT, MDR_TWIST_MOMENT, 4, -1};
  const int normal = input.PickValueInArray(kNormal);
  const double normal_value =
      normal == MDR_NORMAL_HOLD && input.ConsumeBool() ? 0 : AnyDouble(input);
  const int twist = input.PickValueInArray(kTwist);
  const double twist_value =
      twist == MDR_TWIST_HOLD && input.ConsumeBool() ? 0 : AnyTwistValue(input);
  const std::vector<unsigned char> before = Snapshot(torsion);
  mdr_step_report report{};
  const int status = mdr_torsion_step(torsion, normal, normal_value, twist, twist_value,
                                      input.ConsumeBool() ? &report : nullptr);
  CheckError(status);
  mdr_torsional_state after{};
  if (mdr_torsion_state(torsion, &after) != MDR_OK) Fail("torsion state");
  if (std::getenv("MDR_CAPI_FUZZ_TRACE") != nullptr) {
    std::fprintf(
        stderr, "torsion step(%d, %.17g, %d, %.17g) -> %d: delta %.17g phi %.17g M %.17g\n", normal,
        normal_value, twist, twist_value, status, after.depth, after.twist, after.twisting_moment);
  }
  if (status != MDR_OK) {
    if (Snapshot(torsion) != before) Fail("a refused torsional step changed the state");
    return;
  }
  if (normal != MDR_NORMAL_HOLD && twist != MDR_TWIST_HOLD) Fail("a step moving both channels");
  // The moment and the full-slip moment are two quadratures of one integral for the quadrature
  // bounds (a fuzzed scene's cone, power law or table): 1e-7 apart at most, as the engine fuzzer
  // allows.
  if (!std::isfinite(after.twisting_moment) ||
      !(std::abs(after.twisting_moment) <= after.full_slip_moment * (1 + 1e-7))) {
    Fail("an accepted torsional step left a moment that is not finite or beyond full slip");
  }
}

void TorsionQuery(const mdr_torsion* torsion, FuzzedDataProvider& input) {
  const size_t capacity = input.ConsumeIntegralInRange<size_t>(0, 16);
  std::vector<double> a(capacity), b(capacity);
  std::vector<std::int32_t> direction(capacity);
  size_t count = 0;
  const bool null_arrays = capacity == 0 && input.ConsumeBool();
  double* first = null_arrays ? nullptr : a.data();
  switch (input.ConsumeIntegral<std::uint8_t>() % 4) {
    case 0: {
      const int status =
          mdr_torsion_slip_intervals(torsion, first, b.data(), direction.data(), capacity, &count);
      CheckError(status);
      if (status == MDR_OUT_OF_RANGE && count <= capacity) Fail("refused though it fitted");
      break;
    }
    case 1: {
      std::vector<double> radii(input.ConsumeIntegralInRange<size_t>(0, capacity + 1));
      for (double& r : radii) r = input.ConsumeBool() ? AnyDouble(input) : 1e-4 * r + 1e-5;
      const int status =
          mdr_torsion_tractions(torsion, radii.data(), radii.size(),
                                input.ConsumeBool() ? first : nullptr, b.data(), capacity);
      CheckError(status);
      if (status == MDR_OK) {
        for (size_t i = 0; i < radii.size(); ++i) {
          if (std::isnan(b[i])) Fail("a route difference that is NaN");
        }
      }
      break;
    }
    case 2: {
      double positive = 0, negative = 0;
      CheckError(mdr_torsion_stiffness(torsion, &positive, &negative));
      break;
    }
    default: {
      double energy = 0;
      CheckError(mdr_torsion_stored_energy(torsion, input.ConsumeBool() ? &energy : nullptr));
    }
  }
}

void Torsion(FuzzedDataProvider& input) {
  mdr_torsional_state state{};
  CheckError(mdr_torsion_state(nullptr, &state));
  CheckError(mdr_torsion_step(nullptr, MDR_NORMAL_DEPTH, 1e-6, MDR_TWIST_HOLD, 0, nullptr));
  mdr_torsion* torsion = TorsionOrigin(input);
  if (torsion == nullptr) return;
  CheckError(mdr_torsion_state(torsion, nullptr));
  CheckRoundTrip(torsion);
  for (int i = 0; i < 32 && input.remaining_bytes() > 0; ++i) {
    if (input.ConsumeIntegral<std::uint8_t>() % 4 == 0) {
      TorsionQuery(torsion, input);
    } else {
      TorsionStep(torsion, input);
      CheckRoundTrip(torsion);
    }
  }
  mdr_torsion_destroy(torsion);
}

}  // namespace

// A number as proto3 JSON writes it (NaN and infinities as strings).
std::string JsonNumber(double value) {
  if (std::isnan(value)) return "\"NaN\"";
  if (std::isinf(value)) return value > 0 ? "\"Infinity\"" : "\"-Infinity\"";
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

std::string JsonArray(FuzzedDataProvider& input, int max_count, double scale) {
  std::string array = "[";
  const int count = input.ConsumeIntegralInRange(0, max_count);
  for (int i = 0; i < count; ++i) {
    const double value =
        input.ConsumeIntegralInRange(0, 15) == 0
            ? AnyDouble(input)
            : scale * std::sin(0.3 * i) + input.ConsumeFloatingPointInRange(-0.1, 0.1) * scale;
    array += (i > 0 ? "," : "") + JsonNumber(value);
  }
  return array + "]";
}

// A request of the analysis in JSON with fuzzed numbers and sizes around H1's scene, so that the
// service's checks of every field are reached (random bytes seldom parse as JSON).
std::string StructuredRequest(int analysis, FuzzedDataProvider& input) {
  const std::string scene =
      R"("scene": {"sphere": {"radius": )" +
      JsonNumber(input.ConsumeBool() ? 0.01 : AnyDouble(input)) +
      R"(}, "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
      "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3}, "friction": )" +
      JsonNumber(input.ConsumeBool() ? 0.3 : AnyDouble(input)) + "}";
  switch (analysis) {
    case MDR_ANALYZE_LOOPS:
      return "{" + scene + R"(, "samples": {"displacement": )" + JsonArray(input, 200, 1e-6) +
             R"(, "tangential_force": )" + JsonArray(input, 200, 20) +
             R"(}, "options": {"normal_force": )" + JsonNumber(AnyDouble(input)) +
             R"(, "reversal_threshold": )" + JsonNumber(AnyDouble(input)) + "}}";
    case MDR_FIT_LOOPS:
      return "{" + scene + R"(, "sets": [{"samples": {"displacement": )" +
             JsonArray(input, 200, 1e-6) + R"(, "tangential_force": )" + JsonArray(input, 200, 20) +
             R"(}, "normal_force": )" + JsonNumber(AnyDouble(input)) +
             R"(}], "free": [{"parameter": "FIT_PARAMETER_FRICTION", "lower": )" +
             JsonNumber(input.ConsumeBool() ? 0.05 : AnyDouble(input)) + R"(, "upper": )" +
             JsonNumber(input.ConsumeBool() ? 0.9 : AnyDouble(input)) +
             R"(}], "max_iterations": )" + std::to_string(input.ConsumeIntegralInRange(-2, 20)) +
             "}";
    case MDR_FRETTING_MAP:
      return "{" + scene + R"(, "normal_forces": )" + JsonArray(input, 4, 100) +
             R"(, "relative_amplitudes": )" + JsonArray(input, 4, 2) + "}";
    default:
      return "{" + scene + R"(, "normal_force": )" + JsonNumber(AnyDouble(input)) +
             R"(, "kind": )" + std::to_string(input.ConsumeIntegralInRange(0, 3)) +
             R"(, "amplitudes": )" + JsonArray(input, 8, 10) + "}";
  }
}

// One analysis on fuzzed bytes (either encoding) or on a structured JSON request: an error has
// no response and names a field; an answer is a NUL-terminated buffer (JSON: an object).
void Analysis(FuzzedDataProvider& input) {
  const int analysis = input.ConsumeIntegralInRange(0, 5);
  const bool structured = input.ConsumeBool();
  const int encoding = structured ? MDR_ENCODING_JSON : input.ConsumeIntegralInRange(0, 2);
  const std::string request =
      structured ? StructuredRequest(analysis, input) : input.ConsumeRemainingBytesAsString();
  const int stop_after = input.ConsumeIntegralInRange(0, 3);  // 0: never
  struct Progress {
    int calls = 0, stop_after = 0;
  } progress{0, stop_after};
  auto callback = [](const void* message, size_t size, void* user) -> int {
    if (message == nullptr || size == 0) Fail("a progress call without a message");
    Progress& p = *static_cast<Progress*>(user);
    return ++p.calls == p.stop_after ? 1 : 0;
  };
  mdr_buffer* response = reinterpret_cast<mdr_buffer*>(1);
  const int status = mdr_analysis_run(analysis, encoding, request.data(), request.size(), callback,
                                      &progress, &response);
  CheckError(status);
  if (status != MDR_OK) {
    if (response != nullptr) Fail("an analysis error with a response");
    if (status == MDR_CANCELLED && progress.calls != progress.stop_after) {
      Fail("cancelled without the callback asking");
    }
    return;
  }
  if (response == nullptr) Fail("an analysis answered without a response");
  const char* data = static_cast<const char*>(mdr_buffer_data(response));
  if (data[mdr_buffer_size(response)] != '\0') Fail("a response not followed by a NUL byte");
  if (encoding == MDR_ENCODING_JSON && data[0] != '{') Fail("a JSON response that is no object");
  mdr_buffer_destroy(response);
}

// ---- The harmonic-balance element (mdr_element) ----

constexpr char kSharedMotionText[] =
    "scene:\n"
    "  sphere: {radius: 0.01}\n"
    "  elastic_pair: {youngs_modulus_1: 210e9, poisson_ratio_1: 0.3, youngs_modulus_2: 210e9,\n"
    "                 poisson_ratio_2: 0.3}\n"
    "  friction: 0.3\n"
    "  interface: {kind: KIND_SHARED_MOTION,\n"
    "              explicit_list: {heights: [0, -0.5e-6, 0], radii: [0.01, 0.005, 0.02]}}\n";

// An element of H1 or of three asperities under a shared motion (mu = 0.3, so |F| <= 0.3 P at
// every instant), pressed to a fuzzed force, or of fuzzed scene bytes (no bound known).
mdr_element* ElementOrigin(FuzzedDataProvider& input, double* friction_limit) {
  const int origin = input.ConsumeIntegral<std::uint8_t>() % 3;
  const double force = input.ConsumeBool() ? 100 : AnyDouble(input);
  mdr_element* element = reinterpret_cast<mdr_element*>(1);
  int status = MDR_OK;
  *friction_limit = origin == 2 ? INFINITY : 0.3 * force;
  if (origin == 2) {
    const std::vector<unsigned char> scene =
        input.ConsumeBytes<unsigned char>(input.ConsumeIntegral<std::uint16_t>());
    status = mdr_element_create(scene.data(), scene.size(), force, &element);
  } else {
    status = mdr_element_create_from_text(origin == 0 ? kH1Text : kSharedMotionText, "element",
                                          force, &element);
  }
  CheckError(status);
  if (status != MDR_OK && element != nullptr) Fail("a refused element with a handle");
  if (status == MDR_OK && element == nullptr) Fail("a created element without a handle");
  return element;
}

// Fuzzed harmonics, sample counts and coefficients: refused by name, or finite coefficients whose
// mean and harmonics the friction limit bounds (|F_h| <= 4/pi max |f|), the same bits again on a
// second call (the element is unchanged), and a finite loss and Jacobian.
void ElementAft(const mdr_element* element, double friction_limit, FuzzedDataProvider& input) {
  static constexpr std::int32_t kSamples[] = {0, 4, 8, 16, 32, 64, 100, 128, -8, 1 << 17};
  std::vector<std::int32_t> harmonics(input.ConsumeIntegralInRange(0, 6));
  for (std::int32_t& h : harmonics) h = input.ConsumeIntegralInRange(-2, 40);
  if (input.ConsumeBool()) {  // mostly a valid list: increasing from 0
    for (std::size_t k = 0; k < harmonics.size(); ++k) harmonics[k] = static_cast<int>(k);
  }
  std::size_t count = 0;
  for (const std::int32_t h : harmonics) count += h == 0 ? 1 : 2;
  if (input.ConsumeIntegral<std::uint8_t>() % 8 == 0) count = input.ConsumeIntegralInRange(0, 12);
  std::vector<double> u(count);
  for (double& value : u) {
    value = input.ConsumeBool() ? input.ConsumeFloatingPointInRange<double>(-3e-6, 3e-6)
                                : AnyDouble(input);
  }
  const std::int32_t samples = input.PickValueInArray(kSamples);
  const bool with_jacobian = input.ConsumeBool();
  std::vector<double> force(count), again(count), jacobian(count * count);
  double loss = NAN, loss_again = NAN;
  const int status =
      mdr_element_aft(element, u.data(), count, harmonics.data(), harmonics.size(), samples,
                      force.data(), with_jacobian ? jacobian.data() : nullptr, &loss);
  CheckError(status);
  if (status != MDR_OK) return;
  if (!std::isfinite(loss)) Fail("an element's loss that is not finite");
  const double bound = friction_limit * (4 / M_PI) * (1 + 1e-9) + 1e-300;
  for (std::size_t i = 0; i < count; ++i) {
    if (!std::isfinite(force[i])) Fail("an element's force coefficient that is not finite");
    if (std::abs(force[i]) > bound) Fail("an element's force coefficient above 4/pi mu P");
  }
  for (const double d : jacobian) {
    if (!std::isfinite(d)) Fail("an element's Jacobian entry that is not finite");
  }
  if (mdr_element_aft(element, u.data(), count, harmonics.data(), harmonics.size(), samples,
                      again.data(), nullptr, &loss_again) != MDR_OK ||
      std::memcmp(force.data(), again.data(), count * sizeof(double)) != 0 ||
      std::memcmp(&loss, &loss_again, sizeof loss) != 0) {
    Fail("an element's second call differs from its first");
  }
}

void Element(FuzzedDataProvider& input) {
  CheckError(mdr_element_aft(nullptr, nullptr, 0, nullptr, 0, 64, nullptr, nullptr, nullptr));
  double friction_limit = 0;
  mdr_element* element = ElementOrigin(input, &friction_limit);
  if (element == nullptr) return;
  for (int i = 0; i < 4 && input.remaining_bytes() > 0; ++i) {
    ElementAft(element, friction_limit, input);
  }
  mdr_element_destroy(element);
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, size_t size) {
  FuzzedDataProvider input(data, size);
  // Inputs whose first byte is 0xF0 or more run the analysis (mdr_analysis_run) instead.
  if (size > 0 && data[0] >= 0xF0) {
    input.ConsumeIntegral<std::uint8_t>();
    Analysis(input);
    return 0;
  }
  // From 0xD0 to 0xDF a harmonic-balance element (mdr_element).
  if (size > 0 && data[0] >= 0xD0 && data[0] < 0xE0) {
    input.ConsumeIntegral<std::uint8_t>();
    Element(input);
    return 0;
  }
  // From 0xE0 to 0xEF a torsional contact (mdr_torsion).
  if (size > 0 && data[0] >= 0xE0) {
    input.ConsumeIntegral<std::uint8_t>();
    Torsion(input);
    return 0;
  }
  // Null handles and outputs are refused, never dereferenced.
  mdr_state state{};
  CheckError(mdr_contact_state(nullptr, &state));
  CheckError(mdr_contact_step(nullptr, MDR_NORMAL_DEPTH, 1e-6, MDR_TANGENTIAL_HOLD, 0, nullptr));
  mdr_contact* contact = Origin(input);
  if (contact == nullptr) return 0;
  CheckError(mdr_contact_state(contact, nullptr));
  CheckRoundTrip(contact);
  for (int i = 0; i < 32 && input.remaining_bytes() > 0; ++i) {
    if (input.ConsumeIntegral<std::uint8_t>() % 4 == 0) {
      Query(contact, input);
    } else {
      Step(contact, input);
      CheckRoundTrip(contact);
    }
  }
  mdr_contact_destroy(contact);
  return 0;
}
