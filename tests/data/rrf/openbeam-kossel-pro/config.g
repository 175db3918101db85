; An OpenBeam Kossel Pro's config.g on a Duet WiFi (RepRapFirmware 1.x/2.x), written for deltacal's tests in the
; shape of github.com/unrepentantgeek/Duet4OBKP 'sys/config.g' (commit 19d9391bfa385d11f636c5f02579a3fd29b3909b).
; Licence of the source: none stated, so the file is not copied: the lines of RepRapFirmware's delta settings and
; their neighbours are kept with the source's numbers, in its order, with its M98 call of local.g and its M501.

; Communication and general
G21                                 	; Work in millimetres
G90                                	; Send absolute coordinates...
M83                                 	; ...but relative extruder moves

; Axis and motor configuration
M574 X2 Y2 Z2 S1			; set endstop configuration (all endstops at high end, active high)
;*** The homed height (H270) is deliberately set too high in the following line.
M665 L300.000 R153 H270 B135.0 X0 Y0 Z0	; set delta radius, diagonal rod length, printable radius and homed height
M666 X0 Y0 Z0 A0.00 B0.00		; put your endstop adjustments here, or let auto calibration find them
M350 X16 Y16 E16 I1    			; Set 16x microstepping with interpolation
M92 X80 Y80 Z80				; Set axis steps/mm

; Tool definitions
M563 P0 D0 H1                       	; Define tool 0
G10 P0 S0 R0                        	; Set tool 0 operating and standby temperatures
M92 E92.6:92.6                       	; Set extruder steps per mm

; Z probe and compensation definition
M558 P4 X0 Y0 Z0			; Z probe is a mechanical probe and is not used for homing any axes
G31 X0 Y0 Z11.959 P500			; Set the zprobe height and threshold (put your own values here)

;*** If you are using axis compensation, put the figures in the following command
M556 S78 X0 Y0 Z0                   	; Axis compensation here

M208 S1 Z-0.2				; set minimum Z
;
T0					; select first hot end

M98 Plocal.g

; load values from config-overrides.g at boot
M501

