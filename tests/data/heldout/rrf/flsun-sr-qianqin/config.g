; A FLSUN Super Racer's config.g on an SKR 1.3 running RepRapFirmware 3, written for deltacal's tests in the shape of
; github.com/qianqin/superracer-rrf 'sys/config.g' (commit 6944ff0cc77dc1cdc457f8ec7f76def3336d5c50). Licence of the
; source: none stated, so the file is not copied: the lines of RepRapFirmware's delta settings, its probe and its M501
; are kept with the source's numbers, comments and alignment, in its order; every other line is left out.
; Configuration file for SKR v1.3 (firmware version 3)
; executed by the firmware on start-up

; General preferences
G90                                            ; send absolute coordinates...
M83                                            ; ...but relative extruder moves
M550 P"FLSUN SuperRacer"                       ; set printer name
M665 R151.67 L315 B132 H330                    ; Set delta radius, diagonal rod length, printable radius and homed height
M666 X0 Y0 Z0                                  ; put your endstop adjustments here, or let auto calibration find them

; Drives
M584 X0 Y1 Z2 E3                               ; set drive mapping
M350 X16 Y16 Z16 E16 I1                        ; configure microstepping with interpolation
M92 X80.00 Y80.00 Z80.00 E410.00               ; set steps per mm

; Axis Limits
M208 Z0 S1                                     ; set minimum Z

; Endstops
M574 X2 S1 P"^xstopmax"                        ; configure active-high endstop for high end on X via pin ^xstopmax
M574 Y2 S1 P"^ystopmax"                        ; configure active-high endstop for high end on Y via pin ^ystopmax
M574 Z2 S1 P"^zstopmax"                        ; configure active-high endstop for high end on Z via pin ^zstopmax

; Z-Probe
M558 P8 C"^!zstop" H8 F120 T12000              ; set Z probe type to switch and the dive height + speeds
G31 P500 X0 Y0 Z20                             ; set Z probe trigger value, offset and trigger height
M557 R130 S26                                  ; define mesh grid

; Load config-override.g from calibration
M501
