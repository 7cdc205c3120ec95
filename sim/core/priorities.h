// Event priorities of the closed loop: at one instant, lower runs first. The physics step that
// advances the world from t to t + step runs last, so everything at t sees the state at t and
// actuator commands set at t are held through the step (zero-order hold).
#pragma once

namespace autonomsim::sim {

inline constexpr int kPriorityWorldChange = 0;   // obstacles appear / disappear
inline constexpr int kPriorityV2IDelivery = 10;  // messages arrive
inline constexpr int kPriorityServer = 15;       // the traffic-light server's lease ticks
inline constexpr int kPriorityClient = 20;       // the cars' intersection clients
// The wheel encoder integrates each physics step just before the samples of its end instant;
// sensors sample the state at t before anything acts on it.
inline constexpr int kPrioritySensorIntegrate = 22;
inline constexpr int kPrioritySensor = 23;
inline constexpr int kPriorityPlatform = 25;  // node timers, job completions on the platform
inline constexpr int kPriorityDriver = 30;    // drivers compute actuator commands
inline constexpr int kPriorityRecord = 40;    // trajectory samples, progress
inline constexpr int kPriorityPhysics = 50;   // the world advances

}  // namespace autonomsim::sim
