% The +mdr package's contract under Octave: results, errors with identifiers that name the
% field, handles released when cleared, analysis calls, progress and its stop.
%   octave-cli package_test.m PACKAGE_DIR SCENE_FILE
arguments = argv();
addpath(arguments{1});
scene_file = arguments{2};

function check(condition, what)
  if ~condition
    error('package_test:failed', 'failed: %s', what);
  end
end

function expect_error(f, identifier, text, what)
  try
    f();
  catch e
    check(strcmp(e.identifier, identifier), sprintf('%s: identifier %s, not %s', what, ...
                                                    e.identifier, identifier));
    check(~isempty(strfind(e.message, text)), sprintf('%s: message "%s" lacks "%s"', what, ...
                                                      e.message, text));
    return
  end
  error('package_test:failed', 'failed: %s raised no error', what);
end

H1 = struct('sphere', struct('radius', 0.01), 'friction', 0.3, 'elastic_pair', ...
            struct('youngs_modulus_1', 210e9, 'poisson_ratio_1', 0.3, ...
                   'youngs_modulus_2', 210e9, 'poisson_ratio_2', 0.3));

% A struct and the scene file give the same contact, bit for bit.
a = mdr.Contact(H1);
b = mdr.Contact(scene_file);
a.step('normal_force', 100);
b.step(struct('normal_force', 100));
check(isequal(a.snapshot(), b.snapshot()), 'struct and file scenes differ');
r = a.step('tangential_force', 12);
s = a.state();
check(r.substeps >= 1 && abs(s.tangential_force - 12) < 1e-9, 'a force step');
[kp, kn] = a.stiffness();
check(kp > 0 && kn > 0, 'stiffness');
check(size(a.slip_intervals(), 2) == 3 && size(a.slip_intervals(), 1) >= 1, 'slip intervals');
[w, edge] = a.jager_weights();
check(size(w, 2) == 3 && edge == 0, 'Jager weights');
t = a.tractions([0, 1e-5, 5e-5], 'jager');
check(isequal(size(t), [3, 4]) && all(t(:, 3) > 0), 'tractions');
restored = mdr.Contact.restore(a.snapshot());
check(isequal(restored.snapshot(), a.snapshot()), 'snapshot round trip');

% Errors: identifiers and the field; a refused step changes nothing.
before = a.snapshot();
expect_error(@() a.step('tangential_force', 31), 'mdr:failedPrecondition', 'tangential_value', ...
             'beyond the friction limit');
expect_error(@() a.step('depth', NaN), 'mdr:invalidArgument', 'normal_value', 'a NaN depth');
expect_error(@() a.step('speed', 1), 'mdr:invalidArgument', 'speed', 'an unknown channel');
expect_error(@() a.step('depth', 1e-6, 'normal_force', 1), 'mdr:invalidArgument', ...
             'second normal channel', 'two normal channels');
expect_error(@() a.tractions(0, 'sideways'), 'mdr:invalidArgument', 'route', 'a bad route');
check(isequal(a.snapshot(), before), 'a refused call changed the contact');
bad = H1;
bad.sphere.radius = -1;
expect_error(@() mdr.Contact(bad), 'mdr:invalidArgument', 'scene.sphere.radius', 'a bad scene');
expect_error(@() mdr_mex('state', uint64(12345)), 'mdr:invalidArgument', 'not a live contact', ...
             'a forged handle');

% Handles are released when their objects are cleared.
live = mdr_mex('live');
clear a b restored
check(mdr_mex('live') == live - 3, 'cleared contacts still hold their handles');

% The analysis on loops recorded by a contact.
c = mdr.Contact(H1);
c.step('normal_force', 100);
u = 1e-6 * sin(2 * pi * (0:300) / 100);
fx = zeros(size(u));
for i = 1:numel(u)
  c.step('displacement', u(i));
  s = c.state();
  fx(i) = s.tangential_force;
end
loops = mdr.analyze_loops(u, fx, 'normal_force', 100, 'scene', H1);
check(numel(loops.cycles) == 2, 'two complete cycles');
check(strcmp(loops.cycles(1).regime, 'REGIME_PARTIAL_SLIP'), 'partial slip');
check(isnan(loops.cycles(1).start_time), 'NaN start time without time samples');
expect_error(@() mdr.analyze_loops(u, fx(1:10)), 'mdr:invalidArgument', ...
             'samples.tangential_force', 'samples of different lengths');
with_nan = u;
with_nan(7) = NaN;
expect_error(@() mdr.analyze_loops(with_nan, fx), 'mdr:invalidArgument', ...
             'samples.displacement[6]', 'a NaN sample');
set = struct('displacement', u, 'tangential_force', fx, 'normal_force', 100);
free = struct('parameter', 'friction', 'lower', 0.05, 'upper', 0.9, 'initial', 0.25);
fit = mdr.fit_loops(H1, set, free, 'displacement_noise', 1e-9, 'force_noise', 0.01);
check(abs(fit.estimates(1).value - 0.3) < 1e-6, 'the fitted friction');
expect_error(@() mdr.fit_loops(H1, set, free, 'progress', @(p) p.iteration >= 1), ...
             'mdr:cancelled', 'progress', 'a fit stopped by its progress function');
expect_error(@() mdr.fit_loops(H1, set, free, 'progress', @(p) error('my:own', 'boom')), ...
             'mdr:progressFailed', 'boom', 'a progress function that fails');
expect_error(@() mdr.fit_loops(H1, set, free, 'iterations', 3), 'mdr:invalidArgument', ...
             'iterations', 'an unknown option');
bb = mdr.backbone(H1, 100, [5 15 25]);
check(numel(bb.loops) == 3 && all(diff([bb.loops.damping_ratio]) > 0), 'the backbone');
expect_error(@() mdr.backbone(H1, 100, 40), 'mdr:invalidArgument', 'amplitudes', ...
             'an amplitude beyond mu F_N');
map = mdr.fretting_map(H1, [50 100], [0.5 2]);
check(numel(map.loads) == 2 && strcmp(map.loads(1).regimes{2}, 'REGIME_GROSS_SLIP'), 'the map');

% A torsional record (the loops above read as a twist in rad and a moment in N m): the figures
% keep their definitions, the friction coefficient is NaN, a scene with torsion classifies each
% cycle against its full-slip moment; the errors name their fields.
twisted = H1;
twisted.torsion = struct('rig_compliance', 0);
record = struct('twist', 1e3 * u, 'twisting_moment', 1e-4 * fx);
tl = mdr.analyze_loops(record, 'normal_force', 100, 'scene', twisted);
check(numel(tl.cycles) == 2 && isnan(tl.cycles(1).friction_coefficient), 'a torsional record');
check(tl.cycles(1).full_slip_moment > tl.cycles(1).force_amplitude, 'the full-slip moment');
check(strcmp(tl.cycles(1).regime, 'REGIME_PARTIAL_SLIP'), 'a torsional regime');
check(abs(tl.cycles(1).force_amplitude - 1e-4 * loops.cycles(1).force_amplitude) < 1e-15, ...
      'M* is the moment column''s Q*');
both = record;
both.displacement = u;
expect_error(@() mdr.analyze_loops(both), 'mdr:invalidArgument', 'samples.twist', ...
             'a record of both pairs');
expect_error(@() mdr.analyze_loops(record, 'normal_force', 100, 'scene', H1), ...
             'mdr:invalidArgument', 'scene.torsion', 'a torsional record with a tangential scene');
expect_error(@() mdr.analyze_loops(struct('twist', u, 'moment', fx)), 'mdr:invalidArgument', ...
             'record.moment: unknown field', 'an unknown record field');
expect_error(@() mdr.fit_loops(twisted, set, free), 'mdr:invalidArgument', 'sets[0].samples', ...
             'a tangential set in a torsional fit');
tb = mdr.backbone(twisted, 100, [1e-4 1e-3], 'actuator_displacement');
check(numel(tb.loops) == 2 && tb.loops(2).force_amplitude > tb.loops(1).force_amplitude, ...
      'the torsional backbone');
% The harmonic-balance element (docs/dynamics.md): its coefficients are an mdr.Contact stepped
% through the same steady period (pressed to 100 N, moved to the period's largest sample, its
% smallest and its largest again, then two periods from there) and summed directly; its Jacobian
% the central differences; the element unchanged by a call; refusals named.
h = [0 1 3];
Nt = 64;
U = [0.05; 1; 0.2; 0.1; -0.3] * 1.5e-6;
tau = 2 * pi * (0:Nt-1)' / Nt;
u = U(1) + U(2) * cos(tau) + U(3) * sin(tau) + U(4) * cos(3 * tau) + U(5) * sin(3 * tau);
e = mdr.ContactElement(H1, 100);
[F, dFdU, energy] = e.aft(U, h, Nt);
c = mdr.Contact(H1);
c.step('normal_force', 100);
[~, top] = max(u);
c.step('displacement', u(top));
c.step('displacement', min(u));
c.step('displacement', u(top));
f = zeros(Nt, 1);
for period = 1:2
  loss = 0;
  for i = 1:Nt
    j = mod(top - 1 + i, Nt) + 1;
    r = c.step('displacement', u(j));
    loss = loss + r.dissipated;
    s = c.state();
    f(j) = s.tangential_force;
  end
end
expected = [mean(f); 2 / Nt * [f' * cos(tau); f' * sin(tau); f' * cos(3 * tau); f' * sin(3 * tau)]];
check(max(abs(F - expected)) <= 1e-12 * max(abs(expected)), 'the element is the stepped period');
check(abs(energy / loss - 1) <= 1e-12, 'the element''s loss is the stepped period''s');
check(isequal(size(dFdU), [5 5]), 'the Jacobian is 5 by 5');
step = 1e-7 * 1.27e-6;
for b = 1:5
  d = zeros(5, 1);
  d(b) = step;
  numeric = (e.aft(U + d, h, Nt) - e.aft(U - d, h, Nt)) / (2 * step);
  check(max(abs(dFdU(:, b) - numeric)) <= 1e-6 * max(abs(dFdU(:))), ...
        sprintf('dF/dU(:, %d) is the central differences', b));
end
check(isequal(e.aft(U, h, Nt), F), 'a second call gives the same bits');
expect_error(@() e.aft(U, h, 100), 'mdr:invalidArgument', 'samples', 'Nt not a power of two');
expect_error(@() e.aft(U, [0 3 1], Nt), 'mdr:invalidArgument', 'harmonics[2]', ...
             'harmonics not increasing');
expect_error(@() e.aft([U; 0], h, Nt), 'mdr:invalidArgument', 'coefficients', ...
             'a coefficient too many');
expect_error(@() e.aft([U(1:2); NaN; U(4:5)], h, Nt), 'mdr:invalidArgument', ...
             'coefficients[2]', 'a NaN coefficient');
expect_error(@() mdr.ContactElement(H1, 0), 'mdr:invalidArgument', 'normal_force', ...
             'no normal force');
expect_error(@() mdr.ContactElement(struct('sphere', struct('radius', -1)), 100), ...
             'mdr:invalidArgument', 'scene.sphere.radius', 'a bad scene');
live = mdr_mex('live');
handle = mdr_mex('element_create', mdr.internal.to_json(struct('scene', H1)), 'h1', 100);
expect_error(@() mdr_mex('state', handle), 'mdr:invalidArgument', 'not a live contact', ...
             'an element handle given to a contact command');
mdr_mex('element_destroy', handle);
clear e c
check(mdr_mex('live') == live - 2, 'a cleared element still holds its handle');
printf('package_test: all checks passed\n');
