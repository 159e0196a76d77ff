% The paper's companion serial dialect, driven from GNU Octave as the authors' numberTran drives
% their Arduino sketch: serialport, writeline z<steps>, y<steps>, x<steps>, then m. The robot is
% our firmware in the emulator (its pty is the serial port); the emulator's truth channel (the
% STEP/DIR pins) says where the motors really are. Expected counts: the switch frame's zero
% computed here from the robot description's [endstops] and motor conversions.
%
% usage: octave-cli companion_robot_test.m <pty> <side_channel_port>
1;

function line = next_line(s, timeout_s)
  % the next line from the firmware: the bytes as they come, split at the line feed, what
  % follows kept for the next call. Not Octave's readline: on a line that is not whole yet
  % (the emulated robot paused mid-line on a loaded machine) instrument-control 0.8's readline
  % calls read(dev) without a count, which fails ("Invalid call to read").
  persistent pending;
  if isempty(pending), pending = ''; end
  t0 = tic;
  while isempty(strfind(pending, "\n"))
    assert(toc(t0) < timeout_s, 'no line from the firmware within %g s', timeout_s);
    n = s.NumBytesAvailable;
    if n > 0
      pending = [pending, char(reshape(read(s, n), 1, []))];
    else
      pause(0.01);
    end
  end
  k = strfind(pending, "\n")(1);
  line = strtrim(pending(1:k - 1));
  pending = pending(k + 1:end);
end

function counts = truth(side)
  % the true motor positions: z= j2= j3= of one TR line
  write(side, uint8(sprintf('query\n')));
  text = '';
  t0 = tic;
  while isempty(regexp(text, 'TR [^\n]*\n', 'once'))
    assert(toc(t0) < 5, 'no TR line');
    n = side.NumBytesAvailable;
    if n > 0, text = [text, char(reshape(read(side, n), 1, []))]; else, pause(0.005); end
  end
  text = regexp(text, 'TR [^\n]*', 'match', 'once');
  counts = [sscanf(regexp(text, ' z=-?\d+', 'match', 'once'), ' z=%d'), ...
            sscanf(regexp(text, ' j2=-?\d+', 'match', 'once'), ' j2=%d'), ...
            sscanf(regexp(text, ' j3=-?\d+', 'match', 'once'), ' j3=%d')];
end

function wait_at(side, want)
  t0 = tic;
  while true
    got = truth(side);
    if isequal(got, want), return; end
    assert(toc(t0) < 30, 'motors at %s, expected %s', mat2str(got), mat2str(want));
    pause(0.05);
  end
end

args = argv();
pty = args{1};
side_port = str2double(args{2});
pkg load instrument-control;

s = serialport(pty, 115200);
configureTerminator(s, 'LF');
side = tcpclient('127.0.0.1', side_port);
% the truth only when asked (it is published at 100 Hz otherwise)
write(side, uint8(sprintf('rate 0\n')));
pause(0.3);
if side.NumBytesAvailable > 0, read(side, side.NumBytesAvailable); end
% a Uno resets when its port opens, and so does the emulated one: the firmware starts after
% about 1.5 s in the bootloader, so ask for its hello until it answers
t0 = tic;
seen = '';
while isempty(strfind(seen, 'HI=1=scara'))
  assert(toc(t0) < 20, 'no hello from the firmware within 20 s');
  writeline(s, 'HI=1=');
  pause(0.5);
  n = s.NumBytesAvailable;
  if n > 0, seen = [seen, char(reshape(read(s, n), 1, []))]; end
end
% setup in version 1 (the same port): no state reports, the dialect on, home
writeline(s, 'SR=0=');
pause(0.3);
flush(s);
writeline(s, 'CF=10=1=');
line = next_line(s, 5);
assert(strcmp(line, 'AK=CF=1='), 'CF=10=1= answered "%s"', line);
writeline(s, 'HM=');
assert(strcmp(next_line(s, 5), 'AK=HM='));
line = next_line(s, 60);
assert(strcmp(line, 'EV=1='), 'homing ended with "%s"', line);

% the zero of the companion frame: where each switch closed (description: Z 0.1225 m, J2 117 deg,
% J3 -77 deg as a joint count plus 0.8 x the J2 motor backed off its switch by 40 steps)
zero_z = round(0.1225 * 205560);
zero_j2 = round(deg2rad(117) * 945);
zero_j3 = round(deg2rad(-77) * 1455) + floor(0.8 * (zero_j2 - 40));
printf('switch frame zero: %d %d %d\n', zero_z, zero_j2, zero_j3);

% the companion scripts' numberTran: three targets, then m
targets = [-6000, -2400, 1500];
writeline(s, sprintf('z%d', targets(1))); pause(0.05);
writeline(s, sprintf('y%d', targets(2))); pause(0.05);
writeline(s, sprintf('x%s', num2str(targets(3) + 0.4))); pause(0.05);  % num2str: x1500.4
writeline(s, 'm');
t0 = tic;
wait_at(side, [zero_z, zero_j2, zero_j3] + targets);
printf('moved to %s in %.2f s (wall)\n', mat2str(truth(side)), toc(t0));

% a second move back part of the way
targets2 = [-3000, -1000, 700];
writeline(s, sprintf('z%d', targets2(1)));
writeline(s, sprintf('y%d', targets2(2)));
writeline(s, sprintf('x%d', targets2(3)));
writeline(s, 'm');
wait_at(side, [zero_z, zero_j2, zero_j3] + targets2);

% a target beyond the limits: an error line, and nothing moves
at = truth(side);
writeline(s, 'z-30000');
line = next_line(s, 5);
printf('refused: %s\n', line);
assert(strcmp(line, 'error: z-30000 beyond the limits -23125..-514'), 'got "%s"', line);
writeline(s, 'm');
writeline(s, 'PI=9=');
assert(strcmp(next_line(s, 5), 'AK=PI=9='));
assert(isequal(truth(side), at), 'the refused target moved the robot');
clear s side;
printf('companion serial dialect: ok\n');
