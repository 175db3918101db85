; config.g of a linear delta running RepRapFirmware 3.x (written for deltacal's tests, in the shape of
; the files RRF's configuration tool writes)
G90                                     ; send absolute coordinates...
M83                                     ; ...but relative extruder moves
M550 P"Test delta; kossel"              ; set printer name (a ';' inside quotes is no comment)
M669 K3                                 ; linear delta kinematics
M665 L269:269.5:268.8 R134.4 H295.6 B115 X0.1 Y-0.2 Z0 ; delta radius, diagonals, homed height, bed radius, corrections
M666 X0.2 Y-0.1 Z-0.1 A0.05 B-0.02     ; endstop adjustments, tilt in percent
M584 X0 Y1 Z2 E3                        ; drive mapping
m350 x16 y16 z16 E16 I1                 ; configure microstepping with interpolation (lower case works too)
M92 X80 Y80 Z80 E420                    ; steps per mm
M208 Z0 S1                              ; set minimum Z
M564 H1                                 ; no moves before homing (limits stay on)
M558 P5 C"zprobe.in" H5 F120 T6000      ; set Z probe type
G31 P500 X0 Y0 Z0                       ; nozzle is the probe
if boards[0].firmwareVersion != ""      ; a meta command: left alone
  echo "configured"
M501                                    ; load config-override.g
