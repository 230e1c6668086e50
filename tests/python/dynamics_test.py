#!/usr/bin/python3
"""The harmonic-balance element through the Python package (mdr.dynamics, issue #51), in this
process (libmdr_c): its coefficients are an in-process session stepped through the same steady
period by hand and transformed by numpy (tmdsimpy's sine-cosine form: the sign of the sine
terms, the ordering), the Jacobian is the central differences, a call changes nothing, bad
arguments are refused naming them, and TmdsimpyForce maps a two-degree-of-freedom system's
harmonic DOFs as tmdsimpy orders them (every DOF of a component, then the next).

Usage: dynamics_test.py --library PATH
"""
import argparse
import sys
import unittest

import numpy as np

import mdr
import mdr.dynamics

ARGS = None

# Reference vector H1 (steel sphere R = 10 mm on a steel flat, mu = 0.3) at 100 N: mu F_N = 30 N
# and a slip distance mu kappa delta of about 1.27 um.
H1 = {"sphere": {"radius": 0.01}, "friction": 0.3,
      "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                       "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3}}
PRESS = 100.0
SLIP = 1.27e-6
HARMONICS = np.array([0, 1, 3])
SAMPLES = 64


def displacement(amplitude):
    """[U0, U1c, U1s, U3c, U3s]: a first harmonic with a third, which makes inner reversals."""
    return np.array([0.05, 1.0, 0.2, 0.1, -0.3]) * amplitude


def samples_of(U):
    tau = 2 * np.pi * np.arange(SAMPLES) / SAMPLES
    u = np.full(SAMPLES, U[0])
    for k, h in enumerate(HARMONICS[1:]):
        u += U[1 + 2 * k] * np.cos(h * tau) + U[2 + 2 * k] * np.sin(h * tau)
    return u


def coefficients_of(f):
    """mean, 2/N sum f cos(h tau), 2/N sum f sin(h tau): tmdsimpy's get_fourier_coeff."""
    spectrum = np.fft.rfft(f)
    out = [spectrum[0].real / SAMPLES]
    for h in HARMONICS[1:]:
        out += [2 * spectrum[h].real / SAMPLES, -2 * spectrum[h].imag / SAMPLES]
    return np.array(out)


class ContactElementTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.element = mdr.dynamics.ContactElement(H1, PRESS, library=ARGS.library)

    @classmethod
    def tearDownClass(cls):
        cls.element.close()

    def stepped_period(self, U):
        """A session pressed to PRESS, moved to the period's largest sample, its smallest and its
        largest again, marched two periods from there: the second's force coefficients and
        loss."""
        u = samples_of(U)
        top = int(np.argmax(u))
        force = np.empty(SAMPLES)
        with mdr.Client.embedded(in_process=True, library=ARGS.library) as local, \
                local.session(H1) as session:
            session.apply({"normal_force": PRESS})
            session.apply([{"displacement": float(x)}
                           for x in (u[top], u.min(), u[top])])
            for period in range(2):
                before = session.query().state.dissipated_energy
                for i in range(1, SAMPLES + 1):
                    j = (top + i) % SAMPLES
                    force[j] = session.apply(
                        {"displacement": float(u[j])}).state.tangential_force
                loss = session.query().state.dissipated_energy - before
        return coefficients_of(force), loss

    def test_the_coefficients_are_the_period_stepped_by_hand(self):
        for amplitude in (0.3 * SLIP, 0.9 * SLIP, 2.5 * SLIP):
            with self.subTest(amplitude=amplitude / SLIP):
                U = displacement(amplitude)
                F, dFdU, loss = self.element.aft(U, HARMONICS, samples=SAMPLES)
                expected, expected_loss = self.stepped_period(U)
                scale = np.abs(expected).max()
                np.testing.assert_allclose(F, expected, rtol=0, atol=1e-12 * scale)
                self.assertAlmostEqual(loss / expected_loss, 1, delta=1e-9)
                self.assertEqual(dFdU.shape, (5, 5))
                # A call changes nothing: the same bits again, without the Jacobian.
                again, none, loss_again = self.element.aft(U, HARMONICS, samples=SAMPLES,
                                                           jacobian=False)
                self.assertIsNone(none)
                self.assertEqual(again.tobytes(), F.tobytes())
                self.assertEqual(loss_again, loss)

    def test_the_jacobian_is_the_central_differences(self):
        for amplitude in (0.3 * SLIP, 2.5 * SLIP):
            U = displacement(amplitude)
            _, dFdU, _ = self.element.aft(U, HARMONICS, samples=SAMPLES)
            step = 1e-7 * SLIP
            numeric = np.empty_like(dFdU)
            for b in range(U.size):
                e = np.zeros(U.size)
                e[b] = step
                up = self.element.aft(U + e, HARMONICS, SAMPLES, jacobian=False)[0]
                down = self.element.aft(U - e, HARMONICS, SAMPLES, jacobian=False)[0]
                numeric[:, b] = (up - down) / (2 * step)
            np.testing.assert_allclose(dFdU, numeric, rtol=0, atol=1e-6 * np.abs(dFdU).max())

    def test_bad_arguments_are_refused_by_name(self):
        U = displacement(SLIP)
        cases = [((U, HARMONICS, 100), "samples"), ((U, [0, 3, 1], SAMPLES), "harmonics[2]"),
                 ((U[:3], HARMONICS, SAMPLES), "coefficients"),
                 ((np.where(np.arange(5) == 2, np.nan, U), HARMONICS, SAMPLES),
                  "coefficients[2]")]
        for arguments, field in cases:
            with self.subTest(field=field), self.assertRaises(mdr.MdrError) as raised:
                self.element.aft(*arguments)
            self.assertEqual(raised.exception.field, field)
        with self.assertRaises(mdr.MdrError) as raised:
            mdr.dynamics.ContactElement(H1, 0.0, library=ARGS.library)
        self.assertEqual(raised.exception.field, "normal_force")
        with self.assertRaises(mdr.MdrError) as raised:
            mdr.dynamics.ContactElement(dict(H1, torsion={}), PRESS, library=ARGS.library)
        self.assertEqual(raised.exception.field, "scene.torsion")
        closed = mdr.dynamics.ContactElement(H1, PRESS, library=ARGS.library)
        closed.close()
        with self.assertRaises(mdr.MdrError):
            closed.aft(U, HARMONICS)

    def test_tmdsimpy_force_orders_the_harmonic_dofs_as_tmdsimpy(self):
        # Two masses with the contact between them: u = x1 - x2, the force +F on 1, -F on 2.
        Q = np.array([[1.0, -1.0]])
        T = np.array([[1.0], [-1.0]])
        force = mdr.dynamics.TmdsimpyForce(Q, T, self.element)
        self.assertEqual(force.nl_force_type(), 1)
        nhc = mdr.dynamics.coefficient_count(HARMONICS)
        self.assertEqual(nhc, 5)
        rng = np.random.default_rng(5)
        X = rng.normal(scale=0.6 * SLIP, size=(nhc, 2))   # [component k, dof i]
        U = X.reshape(-1)                                 # tmdsimpy: dofs of k, then k + 1
        Fnl, dFnldU, dFnldw = force.aft(U, 9000.0, HARMONICS, Nt=SAMPLES)
        F, dFdU, _ = self.element.aft(X[:, 0] - X[:, 1], HARMONICS, SAMPLES)
        np.testing.assert_array_equal(Fnl.reshape(nhc, 2), np.stack([F, -F], axis=1))
        np.testing.assert_array_equal(dFnldw, np.zeros(2 * nhc))
        step = 1e-7 * SLIP
        for column in range(2 * nhc):
            e = np.zeros(2 * nhc)
            e[column] = step
            numeric = (force.aft(U + e, 0.0, HARMONICS, Nt=SAMPLES, calc_grad=False)[0]
                       - force.aft(U - e, 0.0, HARMONICS, Nt=SAMPLES, calc_grad=False)[0])
            np.testing.assert_allclose(dFnldU[:, column], numeric / (2 * step), rtol=0,
                                       atol=1e-6 * np.abs(dFdU).max())
        self.assertEqual(len(force.aft(U, 0.0, HARMONICS, Nt=SAMPLES, calc_grad=False)), 1)
        # A static step moves the pressed contact along its virgin curve: below mu F_N and as
        # stiff as a pressed contact at small u.
        static, stiffness = force.force(np.array([0.5 * SLIP, 0.0]))
        self.assertGreater(static[0], 0)
        self.assertLess(static[0], 0.3 * PRESS)
        self.assertEqual(static[1], -static[0])
        self.assertEqual(stiffness.shape, (2, 2))
        self.assertGreater(stiffness[0, 0], 0)
        self.assertEqual(stiffness[0, 1], -stiffness[0, 0])
        with self.assertRaises(ValueError):
            mdr.dynamics.TmdsimpyForce(np.ones((2, 2)), T, self.element)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--library", required=True)
    ARGS, rest = parser.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)
