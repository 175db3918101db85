; config-override.g file generated in response to M500 at 2019-04-08 20:26
; This is a system-generated file - do not edit
; (deltacal's tests: the Anycubic Kossel's config-override.g, in the shape of github.com/citruspers/Duet-for-Anycubic-Kossel-Linear-Plus
; 'sys/config-override.g' (commit 676d3e7d19a0a24579e2bfa20bb370b2f5091ba2); licence of the source: none stated, so its
; delta parameters and workplace coordinates are kept with its numbers, its heater models left out. Its config.g runs no
; M501: RRF never reads these values at start-up.)
; Delta parameters
M665 L271.500 R134.670 H290.000 B120.0 X0.000 Y0.000 Z0.000
M666 X0.000 Y0.000 Z0.000 A0.00 B0.00
G10 L2 P1 X0.00 Y0.00 Z0.00
G10 L2 P2 X0.00 Y0.00 Z0.00
G10 L2 P3 X0.00 Y0.00 Z0.00
G10 L2 P4 X0.00 Y0.00 Z0.00
G10 L2 P5 X0.00 Y0.00 Z0.00
G10 L2 P6 X0.00 Y0.00 Z0.00
G10 L2 P7 X0.00 Y0.00 Z0.00
G10 L2 P8 X0.00 Y0.00 Z0.00
G10 L2 P9 X0.00 Y0.00 Z0.00
