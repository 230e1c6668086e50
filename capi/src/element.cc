// The harmonic-balance element of the C interface (docs/dynamics.md): a contact, or an
// interface's asperities, pressed once to a constant normal force, then evaluated by AFT for the
// displacement coefficients of every Newton iteration (mdr/core/aft.h).
#include <algorithm>
#include <climits>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "boundary.h"
#include "inputs.h"
#include "mdr/base/validate.h"
#include "mdr/bridge/conversion.h"
#include "mdr/bridge/interface_session.h"
#include "mdr/core/aft.h"
#include "mdr/core/interface.h"
#include "mdr/core/periodic.h"
#include "mdr/mdr.h"

// The handle: the contacts as pressed (at u = 0, energy tracked), copied by every evaluation.
struct mdr_element {
  std::vector<mdr::Contact> pressed;
};

namespace mdr::capi {
namespace {

// A single contact pressed to the normal force, or an interface under a shared motion pressed to
// it as a total (the approach solved exactly), its asperities then each at their own depth.
CallStatus CreateElement(const v1::Scene& scene, double normal_force, mdr_element** out) {
  if (Status s = RequirePositive("normal_force", normal_force); !s.ok()) return s;
  Result<ContactConfig> config = bridge::ToContactConfig(scene, MaxMemoryVertices());
  if (!config.ok()) return config.status();
  if (scene.has_torsion()) {
    return InvalidArgument("scene.torsion",
                           "must be unset: the element is tangential (a torsional one is not "
                           "built yet)");
  }
  config->track_energy = true;
  if (!scene.has_interface()) {
    Result<Contact> contact = PressForPeriod(*config, normal_force);
    if (!contact.ok()) {
      const Status& s = contact.status();
      return s.field() == "normal_force" ? s : s.WithFieldPrefix("scene");
    }
    *out = new mdr_element{{std::move(contact).value()}};
    return OkStatus();
  }
  if (scene.interface().kind() != v1::Interface::KIND_SHARED_MOTION) {
    return InvalidArgument("scene.interface.kind",
                           "must be KIND_SHARED_MOTION: the element's asperities share its motion");
  }
  if (Status s = bridge::CheckInterfaceSize(scene, *config, {}, INT_MAX); !s.ok()) return s;
  Result<Interface> interface = bridge::CreateInterface(scene, *config);
  if (!interface.ok()) return interface.status();
  if (Status s = CheckPeriodicContact(interface->contact(0)); !s.ok()) {
    return s.WithFieldPrefix("scene");
  }
  Step press;
  press.normal = NormalControl::kForce;
  press.normal_value = normal_force;
  if (Status s = interface->Apply(press); !s.ok()) {
    return Status(s.code(), "normal_force", s.message());
  }
  std::vector<Contact> pressed;
  pressed.reserve(interface->size());
  for (std::size_t i = 0; i < interface->size(); ++i) pressed.push_back(interface->contact(i));
  *out = new mdr_element{std::move(pressed)};
  return OkStatus();
}

CallStatus Aft(const mdr_element* element, const double* coefficients, std::size_t count,
               const int32_t* harmonics, std::size_t harmonic_count, int32_t samples, double* force,
               double* jacobian, double* dissipated_energy) {
  if (Status s = RequireNonNull(element, "element"); !s.ok()) return s;
  if (Status s = RequireNonNull(harmonics, "harmonics"); !s.ok()) return s;
  if (Status s = RequireNonNull(coefficients, "coefficients"); !s.ok()) return s;
  if (Status s = RequireNonNull(force, "force"); !s.ok()) return s;
  // Increasing harmonics below samples / 2 <= 32768: a longer list is refused before it is read.
  if (harmonic_count > 32768) {
    return InvalidArgument("harmonic_count",
                           "must be at most 32768, got " + std::to_string(harmonic_count));
  }
  const std::vector<int> h(harmonics, harmonics + harmonic_count);
  AftOptions options;
  options.samples = samples;
  options.jacobian = jacobian != nullptr;
  Result<AftResponse> r =
      ContactAft(element->pressed, std::span<const double>(coefficients, count), h, options);
  if (!r.ok()) return r.status();
  std::copy(r->force.begin(), r->force.end(), force);
  if (jacobian) std::copy(r->jacobian.begin(), r->jacobian.end(), jacobian);
  if (dissipated_energy) *dissipated_energy = r->dissipated_energy;
  return OkStatus();
}

}  // namespace
}  // namespace mdr::capi

extern "C" {

using mdr::capi::Boundary;

int mdr_element_create(const void* scene, size_t size, double normal_force, mdr_element** out) {
  return Boundary("mdr_element_create", [&] {
    return mdr::capi::CreateFromBytes(
        scene, size, out, [&](const mdr::v1::Scene& parsed, mdr_element** handle) {
          return mdr::capi::CreateElement(parsed, normal_force, handle);
        });
  });
}

int mdr_element_create_from_text(const char* text, const char* name, double normal_force,
                                 mdr_element** out) {
  return Boundary("mdr_element_create_from_text", [&] {
    return mdr::capi::CreateFromText(
        text, name, out, [&](const mdr::v1::Scene& parsed, mdr_element** handle) {
          return mdr::capi::CreateElement(parsed, normal_force, handle);
        });
  });
}

void mdr_element_destroy(mdr_element* element) { delete element; }

int mdr_element_aft(const mdr_element* element, const double* coefficients, size_t count,
                    const int32_t* harmonics, size_t harmonic_count, int32_t samples, double* force,
                    double* jacobian, double* dissipated_energy) {
  return Boundary("mdr_element_aft", [&] {
    return mdr::capi::Aft(element, coefficients, count, harmonics, harmonic_count, samples, force,
                          jacobian, dissipated_energy);
  });
}

}  // extern "C"
