// Drive-level meaning of a decoded frame from the drive's profile: "drive 2 (E-9): setpoint
// 50.00 Hz; output frequency 49.87 Hz". Today: Modbus RTU and ASCII frames (registers read and
// written, coils, vendor exception codes); a reply is read with the request it answers.
#pragma once

#include <span>
#include <string>

#include "core/message.hpp"
#include "profiles/profile.hpp"

namespace drivetap {

// Empty when the profile says nothing about the frame. `request`: for a reply, the bytes of its
// request (as on the wire), empty when unknown.
std::string annotate_for_drive(const DriveProfile& profile, const Message& message,
                               std::span<const std::uint8_t> request);

// One register value as the profile describes it: "50.00 Hz", "running, forward", "4
// (overcurrent)".
std::string describe_value(const DriveProfile& profile, const RegisterDef& reg, std::uint16_t raw);

}  // namespace drivetap
