% The +mdr package on the capi reference history (tests/capi): prints what service_reference.cc
% writes for the service (reference.txt), compared byte for byte (run_and_compare.cmake).
%   octave-cli reference_caller.m PACKAGE_DIR REFERENCE_DIR SCENE_FILE
arguments = argv();
addpath(arguments{1});
reference_dir = arguments{2};
scene_file = arguments{3};
restore_at = 100;

history = strsplit(strtrim(fileread(fullfile(reference_dir, 'history.txt'))), "\n");
steps = cell(numel(history), 4);
for i = 1:numel(history)
  f = strsplit(strtrim(history{i}));
  steps(i, :) = {str2double(f{1}), hex2num(f{2}), str2double(f{3}), hex2num(f{4})};
end
normal = {'', 'depth', 'depth_increment', 'normal_force'};
tangential = {'', 'displacement', 'displacement_increment', 'tangential_force'};

function h = hexd(values)
  h = strjoin(arrayfun(@(v) upper(num2hex(v)), values, 'UniformOutput', false), ' ');
end

function run_steps(c, steps, normal, tangential)
  for i = 1:size(steps, 1)
    channels = {};
    if steps{i, 1} ~= 0, channels = [channels, {normal{steps{i, 1} + 1}, steps{i, 2}}]; end
    if steps{i, 3} ~= 0, channels = [channels, {tangential{steps{i, 3} + 1}, steps{i, 4}}]; end
    c.step(channels{:});
    s = c.state();
    printf('S %s\n', hexd([s.depth, s.tangential_displacement, s.contact_radius, ...
                           s.normal_force, s.tangential_force, s.dissipated_energy]));
  end
end

c = mdr.Contact(scene_file);
run_steps(c, steps, normal, tangential);
clear c
fid = fopen(fullfile(reference_dir, 'snapshot.pb'), 'r');
snapshot = fread(fid, Inf, 'uint8=>uint8')';
fclose(fid);
c = mdr.Contact.restore(snapshot);
run_steps(c, steps(restore_at + 1:end, :), normal, tangential);
[kp, kn] = c.stiffness();
printf('K %s\n', hexd([kp, kn]));
[w, edge] = c.jager_weights();
printf('J %d %s\n', size(w, 1), hexd(edge));
for i = 1:size(w, 1), printf('W %s\n', hexd(w(i, :))); end
s = c.state();
t = c.tractions(s.contact_radius * (0:7) / 8, 'both');
for k = 1:8, printf('T %s\n', hexd(t(k, :))); end
intervals = c.slip_intervals();
printf('L %d\n', size(intervals, 1));
for i = 1:size(intervals, 1)
  printf('I %s %d\n', hexd(intervals(i, 1:2)), intervals(i, 3));
end
