// The steady periodic response of exact contacts to a sampled periodic tangential displacement,
// with its exact sensitivities (issue #51; docs/dynamics.md): what a harmonic-balance code's
// alternating frequency-time scheme asks of a contact element at every Newton iteration.
//
// At constant normal force the MDR springs are independent play springs with the same input, so
// the contact is a Prandtl-Ishlinskii (Masing) operator: once the path has passed its global
// maximum and minimum, every later period repeats exactly. Each spring that sticks at a sample
// moves rigidly from where it last left its Coulomb bound, at a turning point of the path (its
// memory segment's anchor), so F(t_i) depends on u(t_i) and on the turning points still in the
// memory, and on nothing else: dF_i/du_i is the stiffness of the springs that stick, and
// dF_i/du_j = -2 G* (the radius measure of the springs anchored at turning point j). The
// sensitivities are therefore exact and sparse (a row has 1 + the number of remembered turning
// points entries), wherever the force is differentiable in the samples: a sample that equals an
// earlier turning point, or a turning point that appears or vanishes with the perturbation, is a
// kink of the operator.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "mdr/base/status.h"
#include "mdr/core/contact.h"
#include "mdr/core/interrupt.h"

namespace mdr {

// dF(t_i)/du(t_j) of one period's samples, in compressed rows: row i holds columns
// column[row_begin[i] .. row_begin[i + 1]), increasing, with their values (N/m). The samples are
// periodic: u(t_j) is the displacement of sample j in every period.
struct PeriodicJacobian {
  std::size_t samples = 0;
  std::vector<std::uint32_t> row_begin;  // samples + 1 offsets
  std::vector<std::uint32_t> column;
  std::vector<double> value;
  // The entry (i, j), 0 where none is stored (a test's lookup: a search of the row).
  double At(std::size_t i, std::size_t j) const;
};

struct PeriodicOptions {
  // Periods marched from the start state before one is recorded, >= 0. The start state is the
  // contact pressed at u = 0 and moved to the period's global maximum, its global minimum and
  // back to its maximum: at constant normal force the loop is then steady (Masing). A recorded
  // period must also end in the state it began in, bit for bit (the start's memory, made by the
  // virgin loading, can differ from the loop's by round-off near gross slip): one that does not
  // is marched again, up to max_periods periods in all, so that any warm-up gives the same bits.
  int warmup_periods = 0;
  int max_periods = 8;
  bool jacobian = true;  // also the sensitivities
};

struct PeriodicResponse {
  std::vector<double> force;     // F_x(t_j), N, j = 0 .. samples - 1
  double dissipated_energy = 0;  // J over the recorded period
  // The recorded period ended in the state it started from, bit for bit, for every contact: the
  // loop is steady. False only if max_periods were not enough.
  bool steady = false;
  int periods = 0;            // marched in all (the most of any contact), the recorded one included
  PeriodicJacobian jacobian;  // with PeriodicOptions::jacobian
};

// The steady period of a contact of `config` (METHOD_EXACT, no rig) pressed to `normal_force`
// (N, > 0, constant) at u = 0 and driven along the samples of one period of its tangential
// displacement (m, finite, |u| <= 1, at least 2 samples; the path linear between samples, so its
// turning points are samples). Errors name "normal_force", "displacement", "displacement[j]" or
// the config's field ("method", "rig"). The interrupt is checked every 4096 samples.
Result<PeriodicResponse> SteadyPeriod(const ContactConfig& config, double normal_force,
                                      std::span<const double> displacement,
                                      const PeriodicOptions& options = {},
                                      const Interrupt& interrupt = {});

// The contact of `config` pressed to `normal_force` (N, > 0) at u = 0 with its energy tracked:
// what the single-contact evaluations start from. Errors name "normal_force" or the config's
// field.
Result<Contact> PressForPeriod(const ContactConfig& config, double normal_force);
// An error of the contacts' overload for one contact, its "contacts[0]." prefix dropped.
Status AsSingleContact(const Status& status);

// What a periodic evaluation requires of a contact before it is driven: the exact method, no rig,
// its energy tracked and u = 0. Errors name the config's field ("method", "rig", "track_energy")
// or "tangential_displacement".
Status CheckPeriodicContact(const Contact& contact);

// The same for contacts already pressed (each at its own constant depth and u = 0: an interface's
// asperities under a shared approach, Interface::contact(i)), all driven by the same
// displacement: the forces, losses and sensitivities summed. A contact out of contact adds
// nothing.
Result<PeriodicResponse> SteadyPeriod(const std::vector<Contact>& pressed,
                                      std::span<const double> displacement,
                                      const PeriodicOptions& options = {},
                                      const Interrupt& interrupt = {});

}  // namespace mdr
