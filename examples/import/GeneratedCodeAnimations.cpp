// GENERATED CODE. DO NOT CHANGE
// (a small servoc example in the shape of a Bottango "export to code" file: a head that looks around)

// Animation Index Key:
// 0: Look around
// 1: Nod


// !!! Do not change the below, unless you know what you are doing.

#include "GeneratedCodeAnimations.h"
#include "src/CodeCommandStreamDataSource.h"

namespace GeneratedCodeAnimations
{
    // setup
    const char SETUP_DATA_0[] PROGMEM = "rSVPin,3,1000,2000,3000,1500\nrSVPin,4,1100,1900,3000,1500\n";
    const char *const SETUP_DATAARRAY[] PROGMEM = {SETUP_DATA_0};

    // animation 0, "Look around"
    const char ANIM_0_DATA0[] PROGMEM = "sC,3,0,1200,4096,400,0,1200,-400,0\nsC,4,0,800,4096,260,0,6000,-260,0\nsC,3,1200,2000,1200,660,0,7000,-660,0\n";
    const char ANIM_0_DATA1[] PROGMEM = "sC,4,800,1600,6000,530,0,3000,-530,0\nsC,3,3200,1200,7000,400,0,4096,-400,0\nsC,4,2400,1200,3000,400,0,4096,-400,0\n\n";
    const char *const ANIM_0_DATAARRAY[] PROGMEM = {ANIM_0_DATA0, ANIM_0_DATA1};
    const char ANIM_0_LOOP[] PROGMEM = "";
    const uint16_t ANIM_0_CONFIG[] PROGMEM = {0, 0, 0, 0, 0, 0, 0, 0};

    // animation 1, "Nod"
    const char ANIM_1_DATA0[] PROGMEM = "sC,4,0,500,4096,160,0,6500,-160,0\nsC,4,500,500,6500,160,0,2500,-160,0\nsC,4,1000,600,2500,200,0,4096,-200,0\n\n";
    const char *const ANIM_1_DATAARRAY[] PROGMEM = {ANIM_1_DATA0};
    const char ANIM_1_LOOP[] PROGMEM = "";
    const uint16_t ANIM_1_CONFIG[] PROGMEM = {0, 0, 0, 0, 0, 0, 0, 0};

    // configs
    const uint16_t *const CONFIGS_ARRAY[] PROGMEM = {ANIM_0_CONFIG, ANIM_1_CONFIG};
}
