% The paper's companion TCP dialect, driven from GNU Octave as the authors' MATLAB scripts drive
% their Unity server: tcpclient, write(t, [len, bytes]), read. A red cube is spawned, picked
% along 60-sample quintic (jtraj-like) paths sent at the scripts' 54 ms pace, carried to the red
% tray and released; the camera's PNG is read back and decoded with imread. What the dialect
% cannot say (it has no replies) is checked over protocol v1 on the simulator's other port.
%
% usage: octave-cli companion_sim_test.m <companion_port> <v1_port> <out_dir>
1;

function send_frame(t, text)
  % one length byte, then the ASCII command: the companion scripts' writeTCP
  b = uint8(text);
  assert(numel(b) >= 1 && numel(b) <= 255);
  write(t, [uint8(numel(b)), b]);
end

function line = read_line(t, timeout_s)
  % one '\n'-terminated v1 line (without it)
  persistent pending;
  if isempty(pending), pending = uint8([]); end
  t0 = tic;
  while true
    k = find(pending == 10, 1);
    if ~isempty(k)
      line = char(pending(1:k-1));
      pending = pending(k+1:end);
      return;
    end
    n = t.NumBytesAvailable;
    if n > 0
      pending = [pending, reshape(read(t, n), 1, [])];
    else
      assert(toc(t0) < timeout_s, 'no reply from the simulator within %g s', timeout_s);
      pause(0.005);
    end
  end
end

function f = fields(line)
  f = strsplit(line, ',');
  f = f(1:end-1);  % every field ends with the delimiter
end

function cubes = objects(v1)
  write(v1, uint8(sprintf('OP,\n')));
  cubes = struct('id', {}, 'color', {}, 'x', {}, 'y', {}, 'z', {});
  while true
    f = fields(read_line(v1, 5));
    if strcmp(f{1}, 'AK'), break; end
    assert(strcmp(f{1}, 'OP'), 'unexpected reply %s', strjoin(f, ','));
    cubes(end+1) = struct('id', str2double(f{2}), 'color', f{3}, 'x', str2double(f{4}) / 1000, ...
                          'y', str2double(f{5}) / 1000, 'z', str2double(f{6}) / 1000);
  end
end

function st = state(v1)
  % ST,seq,t_us,d1_mm,q2_deg,q3_deg,q4_deg,grip,held,mode,
  write(v1, uint8(sprintf('QS,\n')));
  f = fields(read_line(v1, 5));
  assert(strcmp(f{1}, 'ST'));
  st.q = [str2double(f{4}) / 1000, str2double(f{5}), str2double(f{6}), str2double(f{7})];
  st.grip = str2double(f{8});
  st.held = str2double(f{9});
end

function ok = near(a, b)
  % joints equal to the %f rounding of ModRobot (1 um, 1e-6 deg)
  ok = max(abs(a - b) .* [1000, 1, 1, 1]) < 1e-3;
end

function q = ik(x, y, z, q_near)
  % the paper's closed form (its DH table): d1 = z + 0.067; the elbow solution within the
  % limits nearest to q_near; q4 puts the fingers square to the cube (yaw 0 mod 90 deg)
  a1 = 0.067; a2 = 0.092; a3 = 0.095;
  r2 = (x - a1)^2 + y^2;
  c3 = (r2 - a2^2 - a3^2) / (2 * a2 * a3);
  assert(abs(c3) <= 1, 'target out of reach');
  best = [];
  for s = [1, -1]
    q3 = s * acos(c3);
    q2 = atan2(y, x - a1) - atan2(a3 * sin(q3), a2 + a3 * cos(q3));
    q4 = mod(-(q2 + q3), pi / 2);
    c = [z + 0.067, rad2deg(q2), rad2deg(q3), rad2deg(q4)];
    if c(2) < -105 || c(2) > 115 || c(3) < -75 || c(3) > 205, continue; end
    if isempty(best) || norm(c(2:3) - q_near(2:3)) < norm(best(2:3) - q_near(2:3))
      best = c;
    end
  end
  assert(~isempty(best), 'no elbow solution within the limits');
  q = best;
end

function q = move(t, q0, q1, n)
  % a quintic in joint space (jtraj's polynomial), n samples, one ModRobot every 54 ms as the
  % companion scripts' func_data: d1 in metres, joints 2..4 in degrees, a trailing field
  for k = 1:n
    s = (k - 1) / (n - 1);
    b = 10 * s^3 - 15 * s^4 + 6 * s^5;
    q = q0 + (q1 - q0) * b;
    send_frame(t, sprintf('ModRobot:%f,%f,%f,%f,d%%', q(1), q(2), q(3), q(4)));
    pause(0.054);
  end
end

args = argv();
port = str2double(args{1});
v1_port = str2double(args{2});
out_dir = args{3};
pkg load instrument-control;

t = tcpclient('127.0.0.1', port);
v1 = tcpclient('127.0.0.1', v1_port);
write(v1, uint8(sprintf('HI,1,\n')));
assert(strncmp(read_line(v1, 5), 'HI,1,scaratwin-sim,', 19));
send_frame(t, 'Name:Octave');

% spawn: NewObj 1 is red, where the scene's colour button puts it. The dialect has no replies
% and the two connections are served apart: every check waits for its condition (5 s at most).
send_frame(t, 'NewObj:1');
t0 = tic;
do
  c = objects(v1);
until numel(c) > 0 || toc(t0) > 5
assert(numel(c) == 1 && strcmp(c(1).color, 'red'), 'NewObj:1 did not spawn one red cube');
printf('red cube %d at %.1f, %.1f mm\n', c(1).id, 1000 * c(1).x, 1000 * c(1).y);

% pick: over the cube (60 samples), down to grasp height, grab
home = [0.12, 0, 0, 0];
above = ik(c(1).x, c(1).y, 0.01, home);
grasp = ik(c(1).x, c(1).y, -0.02, above);
q = move(t, home, above, 60);
q = move(t, q, grasp, 10);
t0 = tic;
do
  st = state(v1);
until near(st.q, grasp) || toc(t0) > 5
assert(near(st.q, grasp), 'the virtual robot is not where ModRobot put it: %s', mat2str(st.q, 6));
send_frame(t, 'ModGrab:1');
t0 = tic;
do
  st = state(v1);
until st.grip == 1 || toc(t0) > 5
assert(st.grip == 1 && st.held == c(1).id, 'ModGrab:1 holds %d, not cube %d', st.held, c(1).id);

% a bad frame changes nothing and the connection stays up
write(t, uint8(0));
send_frame(t, 'ModRobot:0.1,200,0,0');
send_frame(t, 'ModRobot:0.1,NaN,0,0');
send_frame(t, 'Name:after-the-bad-frames');
pause(0.3);
st = state(v1);
assert(near(st.q, grasp), 'a bad frame moved the robot');

% place: up, over the red tray (60 samples), release
tray = [0.130, -0.136];
lift = ik(c(1).x, c(1).y, 0.01, grasp);
drop = ik(tray(1), tray(2), 0.0, lift);
q = move(t, q, lift, 10);
q = move(t, q, drop, 60);
send_frame(t, 'ModGrab:0');
t0 = tic;
do
  pause(0.05);
  st = state(v1);
  c = objects(v1);
until (st.grip == 0 && c(1).z < -0.01) || toc(t0) > 5
pause(0.5);  % let it settle in the tray
st = state(v1);
assert(st.grip == 0 && st.held == -1, 'ModGrab:0 did not release');
c = objects(v1);
miss_mm = 1000 * hypot(c(1).x - tray(1), c(1).y - tray(2));
printf('cube in the red tray: %.1f mm from its centre, z %.1f mm\n', miss_mm, 1000 * c(1).z);
assert(miss_mm < 15, 'the cube is %.1f mm from the red tray''s centre', miss_mm);
assert(c(1).z < -0.01, 'the cube did not come down (z %.1f mm)', 1000 * c(1).z);

% camera: the raw PNG, read until no bytes are left, decoded with imread
flush(t);
send_frame(t, 'Camera:Center,,image');
bytes = uint8([]);
t0 = tic;
while isempty(bytes) && toc(t0) < 10, pause(0.01); bytes = [bytes, reshape(read(t, t.NumBytesAvailable), 1, [])]; end
quiet = tic;
while toc(quiet) < 0.3
  n = t.NumBytesAvailable;
  if n > 0, bytes = [bytes, reshape(read(t, n), 1, [])]; quiet = tic; else, pause(0.01); end
end
file = fullfile(out_dir, 'companion_image.png');
fid = fopen(file, 'w'); fwrite(fid, bytes, 'uint8'); fclose(fid);
img = imread(file);
printf('camera: %d bytes of PNG, %dx%dx%d\n', numel(bytes), columns(img), rows(img), size(img, 3));
assert(isequal(size(img), [480, 640, 3]), 'image size %s', mat2str(size(img)));
% the red cube in the picture: reddish pixels exist
red = img(:, :, 1) > 150 & img(:, :, 2) < 90 & img(:, :, 3) < 90;
assert(nnz(red) > 50, 'no red cube in the picture (%d red pixels)', nnz(red));
printf('red pixels: %d\n', nnz(red));
clear t v1;
printf('companion TCP dialect: ok\n');
