"""The glove board link without ROS (docs/spec/hardware.md): frames, messages, both ends.

:mod:`.framing` (COBS, CRC-16), :mod:`.messages` (types and byte layouts), :mod:`.board` (the
board's state machine), :mod:`.link` (the host's: handshake, supervision, reconnection),
:mod:`.timing` (board time on the host clock, round trips), :mod:`.port` (pyserial) and
:mod:`.emulator` (``mcu_emulator``: the simulated glove behind an emulated board on a pty). The
ROS bridge is :mod:`exodigit_nodes.nodes.hardware`.
"""
