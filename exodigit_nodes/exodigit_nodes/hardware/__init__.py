"""The glove board link without ROS (docs/spec/hardware.md): frames, messages, both ends.

:mod:`.framing` (COBS, CRC-16), :mod:`.messages` (types and byte layouts), :mod:`.board` (the
board's state machine), :mod:`.link` (the host's: handshake, supervision, reconnection),
:mod:`.timing` (board time on the host clock, round trips), :mod:`.port` (pyserial),
:mod:`.bridge` (the bridge's safety rules) and ``mcu_emulator``: :mod:`.emulated_board` (the
simulated glove behind the board's protocol), :mod:`.pty_line` (its line on a pty) and
:mod:`.emulator` (the program). The ROS bridge is :mod:`exodigit_nodes.nodes.hardware`.
"""
