// The FC profile's control and status words (docs/protocols.md §4; 002 §7.11.1 CTW, §7.11.2 STW):
// the one table of each word's bits. The FC frame line reads them, and so does the VLT AQUA
// profile (`bits = "danfoss_fc.ctw"`) for the same words read over Modbus (registers 50000, 50200).
#pragma once

#include <array>

#include "core/word_bits.hpp"

namespace drivetap::danfoss_fc {

// §7.11.1. Meanings of 0 that every telegram carries (preset/set-up 0, "no function") are left
// unnamed. Bit 06 starts only "if the other start conditions are met" (bits 02, 03, 04 = 1);
// with bit 10 = 0 the word is ignored.
inline constexpr std::array kCtwBitNames = {
    BitName{0, "", "preset ref. select bit 0 = 1"},  // bits 01/00 pick 3-10[0..3]
    BitName{1, "", "preset ref. select bit 1 = 1"},
    BitName{2, "DC brake", "ramp"},  // 2-01 current, 2-02 time
    BitName{3, "coast", "no coast"},
    BitName{4, "quick stop", "ramp"},  // quick stop ramp 3-81
    BitName{5, "freeze output frequency", "use ramp"},
    BitName{6, "ramp stop", "start"},
    BitName{7, "", "reset"},  // on the rising edge
    BitName{8, "", "jog"},    // jog speed 3-19
    BitName{9, "", "ramp 2"},
    BitName{10, "data not valid", "data valid"},
    BitName{11, "", "relay 01 on"},              // if 5-40 = "control word bit 11"
    BitName{12, "", "relay 02 on"},              // table: relay 02; bit 12 text: "relay 04"
    BitName{13, "", "set-up select bit 0 = 1"},  // bits 14/13 pick set-up 1..4
    BitName{14, "", "set-up select bit 1 = 1"},
    BitName{15, "", "reverse"},  // only if 8-54 = serial, OR or AND
};

// §7.11.2. Bit 5 is unused. If communication with an option fails, every bit is 0.
inline constexpr std::array kStwBitNames = {
    BitName{0, "control not ready", "control ready"},
    BitName{1, "drive not ready", "drive ready"},
    BitName{2, "coasting", "enabled"},
    BitName{3, "", "trip"},  // reset needed
    BitName{4, "", "error (no trip)"},
    BitName{6, "", "trip lock"},
    BitName{7, "", "warning"},
    BitName{8, "speed != reference", "speed = reference"},
    BitName{9, "local control", "bus control"},
    BitName{10, "frequency out of range", "frequency within limits"},  // limits 4-11 / 4-13
    BitName{11, "not running", "running"},   // table: 0 = "not used"; text: 0 = not running
    BitName{12, "", "stopped, auto start"},  // inverter overheat, restarts when cooled
    BitName{13, "", "voltage exceeded"},     // DC link voltage too low or too high
    BitName{14, "", "torque exceeded"},      // current limit 4-18
    BitName{15, "", "timer exceeded"},       // motor/drive thermal timer over 100 %
};

inline constexpr WordBits kCtwBits{"danfoss_fc.ctw", "FC profile control word (CTW)", kCtwBitNames};
inline constexpr WordBits kStwBits{"danfoss_fc.stw", "FC profile status word (STW)", kStwBitNames};
inline constexpr const WordBits* kAllWords[] = {&kCtwBits, &kStwBits};

}  // namespace drivetap::danfoss_fc
