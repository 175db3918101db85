; config-override.g file generated in response to M500 at 2024-03-01 12:00
; This is a system-generated file - do not edit
; Delta parameters
M665 L269.000:269.500:268.800 R134.500 H295.700 B115.0 X0.100 Y-0.200 Z0.000
M666 X0.200 Y-0.100 Z-0.100 A0.05 B-0.02
