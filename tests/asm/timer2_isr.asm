; Timer2 auto-reload interrupt every PERIOD cycles toggles P1.1; the main
; program idles in SJMP $.
	.area CSEG (ABS,CODE)
	.org 0x0000
PERIOD = 500
	.globl main, t2_isr
	ljmp main
	.org 0x002B
t2_isr:
	clr tf2               ; 1
	cpl p1.1              ; 1
	reti                  ; 2
	.org 0x0040
main:
	mov rcap2h,#>(0x10000-PERIOD)
	mov rcap2l,#<(0x10000-PERIOD)
	mov th2,#>(0x10000-PERIOD)
	mov tl2,#<(0x10000-PERIOD)
	setb et2
	setb ea
	setb tr2
idle:	sjmp idle
