; Cycle-exact port writes of several instruction kinds on P1.0.
; Each write is reported at the end of the writing instruction; the
; expected cycle of every write is in the comment (start cycle + length).
	.area CSEG (ABS,CODE)
	.org 0x0000
	.globl start, done
start:
	mov p1,#0xFE          ; 2 cycles: 0..2    write @2  (P1.0 low)
	nop                   ; 1: 2..3
	setb p1.0             ; 1: 3..4           write @4  (high)
	clr p1.0              ; 1: 4..5           write @5  (low)
	mov a,#0x01           ; 1: 5..6
	orl p1,a              ; 1: 6..7           write @7  (high)
	anl p1,#0xFE          ; 2: 7..9           write @9  (low)
	mov r7,#3             ; 1: 9..10
1$:	djnz r7,1$            ; 2 x 3: 10..16
	cpl p1.0              ; 1: 16..17         write @17 (high)
	mov a,#7              ; 1: 17..18
	mov b,#9              ; 2: 18..20
	mul ab                ; 4: 20..24
	xrl p1,#0x01          ; 2: 24..26         write @26 (low)
	lcall sub             ; 2: 26..28
	mov p1,#0xFF          ; 2: 33..35         write @35 (high)
	setb c                ; 1: 35..36
	clr c                 ; 1: 36..37
	mov p1.0,c            ; 2: 37..39         write @39 (low)
	sjmp 2$               ; 2: 39..41
2$:	jnb p1.0,3$           ; 2: 41..43 (P1.0 is 0: jump)
	nop
3$:	setb p1.0             ; 1: 43..44         write @44 (high)
	setb p1.3             ; 1: 44..45         write @45 (P1.3: no change)
	clr p1.3              ; 1: 45..46         write @46 (P1.3 low)
	setb p1.3             ; 1: 46..47         write @47 (P1.3 high)
done:	sjmp done             ; 2 each, forever
sub:
	nop                   ; 1: 28..29
	mov p2,#0x5A          ; 2: 29..31         write @31 (P2)
	ret                   ; 2: 31..33
