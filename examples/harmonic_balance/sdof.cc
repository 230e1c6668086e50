// A single-degree-of-freedom oscillator with an exact contact in parallel (issue #51;
// docs/dynamics.md): its frequency response by harmonic balance with the exact AFT element (Newton
// with pseudo-arclength continuation over frequency), checked against the same oscillator
// integrated in time with the engine (GSL's embedded Runge-Kutta-Fehlberg 4(5)) to steady state.
//
//   m x'' + c x' + k x + F_c(x) = P cos(Omega t)
//
// F_c is the tangential force of H1 (a steel sphere of R = 10 mm on a steel flat, mu = 0.3) pressed
// to 100 N: its stiffness about equals k's, and P spans micro-slip to gross slip.
//
//   mdr_hb_example [--out DIR] [--check]
// writes DIR/frf.csv (the continuation's branches at three excitation levels, H = 7) and
// DIR/check.csv (five frequencies per level: the time integration's steady amplitude beside the
// harmonic-balance amplitude at H = 1, 3, 5, 7). With --check it exits 1 unless every H = 7
// amplitude lies within 1e-3 of the time integration's and the largest error shrinks from H = 1
// to 3, 5 and 7.
#include <gsl/gsl_errno.h>
#include <gsl/gsl_odeiv2.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "mdr/core/aft.h"
#include "mdr/core/material.h"
#include "mdr/core/periodic.h"

namespace {

using mdr::AftResponse;
using mdr::Contact;
constexpr double kPi = std::numbers::pi;
constexpr int kSamples = 1024;  // AFT samples per period (256 alias to about 5e-5 of x)

struct Oscillator {
  double mass = 1;         // kg
  double stiffness = 5e7;  // N/m, about the contact's own
  double damping = 200;    // N s/m: 1.1 % of critical
  Contact contact;         // pressed, at u = 0
};

Oscillator MakeOscillator() {
  mdr::ContactConfig config;
  config.profile = *mdr::MakeSphere(0.01);
  config.material = *mdr::ElasticPair(210e9, 0.3, 210e9, 0.3);
  config.friction = 0.3;
  return {.contact = *mdr::PressForPeriod(config, 100)};
}

// Harmonic balance with harmonics 0 .. H: unknowns x = [X_0, X_1^c, X_1^s, ...] (m).
class Balance {
 public:
  Balance(const Oscillator& o, int harmonics, double force)
      : o_(o), h_(harmonics), force_(force), pressed_{o.contact} {
    for (int h = 0; h <= harmonics; ++h) list_.push_back(h);
  }
  int size() const { return 2 * h_ + 1; }

  // R(x, Omega) and its derivatives by x (J) and by Omega (dR).
  bool Residual(const Eigen::VectorXd& x, double omega, Eigen::VectorXd* r, Eigen::MatrixXd* j,
                Eigen::VectorXd* dr) const {
    std::vector<double> u(x.data(), x.data() + x.size());
    mdr::Result<AftResponse> aft = mdr::ContactAft(pressed_, u, list_, Options());
    if (!aft.ok()) {
      std::fprintf(stderr, "AFT: %s\n", aft.status().ToString().c_str());
      return false;
    }
    const int n = size();
    r->setZero(n);
    j->setZero(n, n);
    dr->setZero(n);
    for (int a = 0; a < n; ++a) {
      (*r)(a) = aft->force[a];
      for (int b = 0; b < n; ++b) (*j)(a, b) = aft->jacobian[a * n + b];
    }
    (*r)(0) += o_.stiffness * x(0);
    (*j)(0, 0) += o_.stiffness;
    for (int h = 1; h <= h_; ++h) {
      const int c = 2 * h - 1, s = 2 * h;
      const double diagonal = o_.stiffness - o_.mass * h * h * omega * omega;
      const double cross = o_.damping * h * omega;
      (*r)(c) += diagonal * x(c) + cross * x(s);
      (*r)(s) += diagonal * x(s) - cross * x(c);
      (*j)(c, c) += diagonal, (*j)(c, s) += cross;
      (*j)(s, s) += diagonal, (*j)(s, c) -= cross;
      (*dr)(c) += -2 * o_.mass * h * h * omega * x(c) + o_.damping * h * x(s);
      (*dr)(s) += -2 * o_.mass * h * h * omega * x(s) - o_.damping * h * x(c);
    }
    (*r)(1) -= force_;  // P cos(Omega t)
    return true;
  }

  // Newton at fixed Omega from x; true when |dx| fell below 1e-12 of |x|.
  bool Solve(double omega, Eigen::VectorXd* x) const {
    Eigen::VectorXd r, dr;
    Eigen::MatrixXd j;
    for (int iteration = 0; iteration < 60; ++iteration) {
      if (!Residual(*x, omega, &r, &j, &dr)) return false;
      const Eigen::VectorXd dx = j.fullPivLu().solve(-r);
      *x += dx;
      if (dx.norm() <= 1e-12 * x->norm()) return true;
    }
    return false;
  }

  // The amplitude of x(t): its largest |x| over a fine sampling of one period.
  static double Amplitude(const Eigen::VectorXd& x) {
    const int harmonics = static_cast<int>(x.size() - 1) / 2;
    double peak = 0;
    for (int j = 0; j < 16384; ++j) {
      const double tau = 2 * kPi * j / 16384;
      double v = x(0);
      for (int h = 1; h <= harmonics; ++h) {
        v += x(2 * h - 1) * std::cos(h * tau) + x(2 * h) * std::sin(h * tau);
      }
      peak = std::max(peak, std::abs(v));
    }
    return peak;
  }

 private:
  static mdr::AftOptions Options() {
    mdr::AftOptions options;
    options.samples = kSamples;
    return options;
  }
  const Oscillator& o_;
  int h_;
  double force_;
  std::vector<Contact> pressed_;
  std::vector<int> list_;
};

// The linear oscillator's response with the contact stuck (its stiffness k_c), a start for Newton.
Eigen::VectorXd StuckStart(const Oscillator& o, int harmonics, double force, double omega) {
  const double k = o.stiffness + o.contact.tangential_stiffness().positive;
  const std::complex<double> z(k - o.mass * omega * omega, o.damping * omega);
  const std::complex<double> x = force / z;  // x = Re(X e^{i Omega t}) = Xr cos - Xi sin
  Eigen::VectorXd start = Eigen::VectorXd::Zero(2 * harmonics + 1);
  start(1) = x.real(), start(2) = -x.imag();
  return start;
}

// Pseudo-arclength continuation over Omega in [from, to]: each point (x, Omega) predicted along
// the branch's tangent and corrected by Newton on the residual plus the arclength condition.
std::vector<std::pair<double, Eigen::VectorXd>> Continue(const Balance& b, const Oscillator& o,
                                                         double force, double from, double to) {
  std::vector<std::pair<double, Eigen::VectorXd>> branch;
  Eigen::VectorXd x = StuckStart(o, (b.size() - 1) / 2, force, from);
  if (!b.Solve(from, &x)) return branch;
  branch.push_back({from, x});
  const int n = b.size();
  // Scale: Omega in units of from, x in units of its norm (the arclength mixes both).
  const double x_scale = std::max(x.norm(), 1e-12), w_scale = from;
  Eigen::VectorXd tangent = Eigen::VectorXd::Zero(n + 1);
  tangent(n) = 1;
  double step = 0.01;
  double omega = from;
  while (omega < to && branch.size() < 4000) {
    Eigen::VectorXd z(n + 1);
    z.head(n) = x / x_scale, z(n) = omega / w_scale;
    Eigen::VectorXd guess = z + step * tangent;
    bool converged = false;
    Eigen::VectorXd r, dr;
    Eigen::MatrixXd j;
    for (int iteration = 0; iteration < 30; ++iteration) {
      const Eigen::VectorXd xs = guess.head(n) * x_scale;
      const double ws = guess(n) * w_scale;
      if (!b.Residual(xs, ws, &r, &j, &dr)) return branch;
      Eigen::MatrixXd a(n + 1, n + 1);
      a.topLeftCorner(n, n) = j * x_scale;
      a.topRightCorner(n, 1) = dr * w_scale;
      a.bottomRows(1) = tangent.transpose();
      Eigen::VectorXd rhs(n + 1);
      rhs.head(n) = -r;
      rhs(n) = -(tangent.dot(guess - z) - step);
      const Eigen::VectorXd d = a.fullPivLu().solve(rhs);
      guess += d;
      if (d.norm() <= 1e-11 * guess.norm()) {
        converged = true;
        break;
      }
    }
    if (!converged) {
      step /= 2;
      if (step < 1e-7) break;
      continue;
    }
    Eigen::VectorXd next_tangent = guess - z;
    next_tangent.normalize();
    if (next_tangent.dot(tangent) < 0) next_tangent = -next_tangent;
    tangent = next_tangent;
    x = guess.head(n) * x_scale;
    omega = guess(n) * w_scale;
    branch.push_back({omega, x});
    step = std::min(step * 1.3, 0.02);
  }
  return branch;
}

// The oscillator in time: the contact's force from its committed state, moved along the trial
// displacement on a copy at every stage; committed at every accepted step.
struct TimeModel {
  const Oscillator* o;
  Contact committed;
  double force, omega;
  double ramp;  // s: the excitation grows smoothly from 0 over this time
};

int Derivatives(double t, const double y[], double dydt[], void* data) {
  auto* m = static_cast<TimeModel*>(data);
  Contact trial = m->committed;
  if (!trial.MoveTo(trial.depth(), y[0]).ok()) return GSL_EBADFUNC;
  const Oscillator& o = *m->o;
  dydt[0] = y[1];
  // A smooth ramp (sin^2) of the excitation: the response grows without overshoot, so the
  // contact's memory ends holding the steady loop's turning points, as the harmonic balance's
  // periodic state does (a hysteretic oscillator remembers its largest excursion: a transient
  // that overshot would shift its loop for good).
  const double envelope = t >= m->ramp ? 1 : std::pow(std::sin(kPi / 2 * t / m->ramp), 2);
  dydt[1] = (envelope * m->force * std::cos(m->omega * t) - o.damping * y[1] - o.stiffness * y[0] -
             trial.tangential_force()) /
            o.mass;
  return GSL_SUCCESS;
}

// The steady amplitude: integrated from rest for `periods` periods, the excitation ramped up over
// the first `ramp` of them, the largest |x| over the last one (kPeakSamples points).
constexpr int kPeakSamples = 16384;

double TimeAmplitude(const Oscillator& o, double force, double omega, int periods, int ramp) {
  TimeModel model{&o, o.contact, force, omega, ramp * 2 * kPi / omega};
  gsl_odeiv2_system system{Derivatives, nullptr, 2, &model};
  gsl_odeiv2_step* step = gsl_odeiv2_step_alloc(gsl_odeiv2_step_rkf45, 2);
  gsl_odeiv2_control* control = gsl_odeiv2_control_y_new(1e-13, 1e-10);
  gsl_odeiv2_evolve* evolve = gsl_odeiv2_evolve_alloc(2);
  const double period = 2 * kPi / omega;
  double y[2] = {0, 0}, t = 0, h = period / 512, peak = 0;
  for (int p = 0; p < periods; ++p) {
    // The last period finely: a peak sampled every 2 pi / n is low by up to (pi / n)^2 / 2.
    const int n = p == periods - 1 ? kPeakSamples : 512;
    for (int k = 1; k <= n; ++k) {
      const double until = period * (p + static_cast<double>(k) / n);
      while (t < until) {
        if (gsl_odeiv2_evolve_apply(evolve, control, step, &system, &t, until, &h, y) !=
            GSL_SUCCESS) {
          return std::nan("");
        }
        (void)model.committed.MoveTo(model.committed.depth(), y[0]);
      }
      if (p == periods - 1) peak = std::max(peak, std::abs(y[0]));
    }
  }
  gsl_odeiv2_evolve_free(evolve);
  gsl_odeiv2_control_free(control);
  gsl_odeiv2_step_free(step);
  return peak;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = ".";
  bool check = false;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--out") == 0 && i + 1 < argc) out = argv[++i];
    if (std::strcmp(argv[i], "--check") == 0) check = true;
  }
  std::error_code made;
  std::filesystem::create_directories(out, made);
  std::FILE* f = std::fopen((out + "/frf.csv").c_str(), "w");
  std::FILE* table = std::fopen((out + "/check.csv").c_str(), "w");
  if (f == nullptr || table == nullptr) {
    std::fprintf(stderr, "mdr_hb_example: cannot write frf.csv and check.csv in %s\n", out.c_str());
    return 2;
  }
  gsl_set_error_handler_off();
  const Oscillator o = MakeOscillator();
  const double k_total = o.stiffness + o.contact.tangential_stiffness().positive;
  const double omega0 = std::sqrt(k_total / o.mass);
  const double levels[] = {1.0, 5.0, 25.0};  // N: micro-slip, partial slip, near gross slip
  std::printf("natural frequency (stuck) %.1f rad/s; levels 1, 5, 25 N (mu F_N = 30 N)\n", omega0);

  // The frequency response at H = 7.
  std::fprintf(f, "force_N,omega_rad_s,amplitude_m\n");
  for (double level : levels) {
    const Balance b(o, 7, level);
    for (const auto& [omega, x] : Continue(b, o, level, 0.8 * omega0, 1.1 * omega0)) {
      std::fprintf(f, "%g,%.10g,%.10g\n", level, omega, Balance::Amplitude(x));
    }
  }
  std::fclose(f);

  // The check: five frequencies per level against time integration.
  std::fprintf(table, "force_N,omega_rad_s,time_m,hb1_m,hb3_m,hb5_m,hb7_m\n");
  bool ok = true;
  double worst[4] = {0, 0, 0, 0};  // the largest error at H = 1, 3, 5, 7
  for (double level : levels) {
    for (double ratio : {0.85, 0.93, 0.97, 1.0, 1.05}) {
      const double omega = ratio * omega0;
      const double time = TimeAmplitude(o, level, omega, 400, 200);
      double error[4];
      double amplitude[4];
      for (int k = 0; k < 4; ++k) {
        const int harmonics = 2 * k + 1;
        const Balance b(o, harmonics, level);
        // From the stuck start, through intermediate frequencies to follow the softening branch.
        Eigen::VectorXd x = StuckStart(o, harmonics, level, 0.8 * omega0);
        for (double w = 0.8 * omega0; w < omega; w = std::min(omega, w + 0.01 * omega0)) {
          if (!b.Solve(w, &x)) break;
        }
        if (!b.Solve(omega, &x)) {
          ok = false;
          amplitude[k] = std::nan("");
        } else {
          amplitude[k] = Balance::Amplitude(x);
        }
        error[k] = std::abs(amplitude[k] / time - 1);
      }
      std::printf(
          "P %5.1f N  Omega/omega0 %.2f  time %.6e m  H=1 %.1e  H=3 %.1e  H=5 %.1e  H=7 %.1e\n",
          level, ratio, time, error[0], error[1], error[2], error[3]);
      std::fprintf(table, "%g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g\n", level, omega, time,
                   amplitude[0], amplitude[1], amplitude[2], amplitude[3]);
      for (int k = 0; k < 4; ++k) worst[k] = std::max(worst[k], error[k]);
      ok = ok && error[3] <= 1e-3;
    }
  }
  // The truncation error shrinks with H (pointwise it may not, where it is at the level of the
  // AFT's sampling and the integration's, about 1e-7 of the amplitude).
  ok = ok && worst[3] < worst[2] && worst[2] < worst[1] && worst[1] < worst[0];
  std::fclose(table);
  std::printf("largest error against the time integration: H = 1 %.1e, 3 %.1e, 5 %.1e, 7 %.1e\n",
              worst[0], worst[1], worst[2], worst[3]);
  return check && !ok ? 1 : 0;
}
