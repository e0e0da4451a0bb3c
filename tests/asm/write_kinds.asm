; One write of each kind that can reach a port latch, on P0, P1, P2 and P3.
; Comments: instruction length, start..end cycle, expected write.
	.area CSEG (ABS,CODE)
	.org 0x0000
	mov r0,#0x30          ; 1: 0..1
	mov @r0,#0xC3         ; 1: 1..2
	mov sp,#0x40          ; 2: 2..4
	mov p0,#0x11          ; 2: 4..6    write P0=0x11 @6
	mov p1,#0x00          ; 2: 6..8    write P1=0x00 @8
	inc p1                ; 1: 8..9    write P1=0x01 @9
	dec p1                ; 1: 9..10   write P1=0x00 @10
	mov p1,#2             ; 2: 10..12  write P1=0x02 @12
	djnz p1,.+3           ; 2: 12..14  write P1=0x01 @14 (branch to next)
	jbc p1.0,.+3          ; 2: 14..16  write P1=0x00 @16 (bit cleared)
	mov a,#0x5A           ; 1: 16..17
	xch a,p1              ; 1: 17..18  write P1=0x5A @18
	push acc              ; 2: 18..20  (A=0x00 from P1)
	mov a,#0x33           ; 1: 20..21
	mov p2,a              ; 1: 21..22  write P2=0x33 @22
	mov p2,@r0            ; 2: 22..24  write P2=0xC3 @24
	mov r5,#0x0F          ; 1: 24..25
	mov p2,r5             ; 2: 25..27  write P2=0x0F @27
	mov p3,p2             ; 2: 27..29  write P3=0x0F @29
	pop p3                ; 2: 29..31  write P3=0x00 @31
	xrl p3,a              ; 1: 31..32  write P3=0x33 @32
	orl p0,#0x80          ; 2: 32..34  write P0=0x91 @34
	anl p0,a              ; 1: 34..35  write P0=0x11 @35
	cpl p0.7              ; 1: 35..36  write P0=0x91 @36
	setb c                ; 1: 36..37
	mov p3.6,c            ; 2: 37..39  write P3=0x73 @39
	clr p2.0              ; 1: 39..40  write P2=0x0E @40
	xchd a,@r0            ; 1: 40..41  (not a port write)
	mov 0x31,p1           ; 2: 41..43  (port read, not a write)
	mov p1,p1             ; 2: 43..45  write P1=0x5A @45 (same value)
stop:	sjmp stop
