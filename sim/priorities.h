// Event priorities of the closed loop: at one instant, lower runs first. The physics step that
// advances the world from t to t + step runs last, so everything at t sees the state at t and
// actuator commands set at t are held through the step (zero-order hold).
#pragma once

namespace autonomsim::sim {

inline constexpr int kPriorityWorldChange = 0;   // obstacles appear / disappear
inline constexpr int kPriorityV2IDelivery = 10;  // messages arrive
inline constexpr int kPriorityServer = 15;       // the traffic-light server's lease ticks
inline constexpr int kPriorityClient = 20;       // the cars' intersection clients
inline constexpr int kPriorityDriver = 30;       // drivers compute actuator commands
inline constexpr int kPriorityRecord = 40;       // trajectory samples, progress
inline constexpr int kPriorityPhysics = 50;      // the world advances

}  // namespace autonomsim::sim
