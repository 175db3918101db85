; An OpenBeam Kossel Pro's local.g (run by config.g's M98 Plocal.g), written for deltacal's tests in the shape of
; github.com/unrepentantgeek/Duet4OBKP 'sys/local.g' (commit 02c443661cb88087acefaf1170299c1f835d5d23); licence of
; the source: none stated, so only its comments and its commented-out M579 are kept.
; Put local machine overrides in this file.  It is run after config.g, but before config-overrides.g

; Compensate for delta inaccuracies
; Uncomment the following line and adjust the X and Y values to grow/shrink in the X/Y axes
;M579 X1.005 Y1.005 ; compensate for delta geometry, grow ~0.5% in X and Y
