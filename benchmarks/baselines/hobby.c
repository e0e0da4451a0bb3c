/*
 * hobby.c: 8 servos on P1 the usual hobby way.
 *
 * AT89C52 at 12 MHz (Timer0 counts 1 us per tick). The 20 ms frame is split
 * into eight 2.5 ms slots, one per servo: at the start of slot i the Timer0
 * interrupt raises P1.i and sets the timer to fire again after the pulse
 * width 500 + 8 N us; that interrupt lowers the line and sets the timer for
 * the rest of the slot. Build: sdcc -mmcs51 --model-small hobby.c
 */
#include <8052.h>

#define SERVOS   8
#define SLOT_US  2500u
#define MIN_US   20u              /* Timer0 reloaded with 0 would count 65536 us */

/* Servo positions N = 0..250: pulse width 500 us + 8 us x N. */
volatile unsigned char position[SERVOS] = {0, 1, 125, 125, 200, 249, 250, 60};

static unsigned char slot;        /* servo whose slot is running */
static __bit pulse_on;            /* its line is high */

/* Timer0 overflows `us` microseconds after this. */
#define TIMER0_SET(us) do { unsigned int count_ = 65536u - (us); \
                            TH0 = count_ >> 8; TL0 = count_ & 0xFF; } while (0)

void timer0_isr(void) __interrupt(1)
{
    unsigned int width = 500u + 8u * position[slot];

    if (!pulse_on) {
        P1 |= (unsigned char)(1 << slot);
        TIMER0_SET(width);
        pulse_on = 1;
    } else {
        unsigned int rest = SLOT_US - width;
        if (rest < MIN_US)
            rest = MIN_US;
        P1 &= (unsigned char)~(1 << slot);
        TIMER0_SET(rest);
        pulse_on = 0;
        slot = (slot + 1) & (SERVOS - 1);
    }
}

void main(void)
{
    P1 = 0;                       /* all servo lines low */
    slot = 0;
    pulse_on = 0;

    TMOD = (TMOD & 0xF0) | 0x01;  /* Timer0 mode 1: 16-bit */
    TIMER0_SET(100);              /* first slot starts shortly */
    TR0 = 1;
    ET0 = 1;
    EA = 1;

    for (;;) {
        /* the main program would update position[] here */
    }
}
