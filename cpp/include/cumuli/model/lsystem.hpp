// L-system clouds (Jiménez de Parga & Gómez Palomo 2018, §3.6.2, eq. 18, Figs. 11–12).
//
// A general interpreter: rules rewrite single ASCII symbols in parallel for a number of
// iterations, then a 3D turtle walks the string and places a sphere for every drawing symbol.
//
// Turtle (Prusinkiewicz & Lindenmayer's conventions, angles δ in degrees). The frame is heading
// H, up U and left L = U × H (so H × L = U). Rotations follow the right-hand rule about the named
// axis of the current frame:
//   +  yaw left    about U by +δ        −  yaw right   about U by −δ
//   &  pitch down  about L by +δ        ^  pitch up    about L by −δ
//   \  roll left   about H by −δ        /  roll right  about H by +δ
//   |  turn around about U by 180°
//   [  push position and frame         ]  pop them (a ']' with nothing pushed is an error)
// Every drawing symbol (default "XY") draws a radius r ∈ [radius_lo, radius_hi], places a sphere
// of radius r at the turtle and then advances by r · s, s ∈ [step_lo, step_hi] (the paper's
// "proportional random radius and length" per placement, Fig. 11: the spacing scales with the
// sphere, so neighbours overlap alike at every size). Move-only symbols (default "f", as in
// ABOP) draw r and s the same way and advance without placing. Other symbols are ignored by the
// turtle. δ is fixed when angle_lo == angle_hi, otherwise drawn uniformly per turn (Fig. 12b).
// All random numbers come from one cumuli::Rng in string order: same seed, same cloud.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

namespace cumuli {

struct LSystemRules {
  // rule[c] is the replacement of symbol c; has_rule[c] says whether c is rewritten at all
  // (a symbol without a rule is copied; a rule may map to the empty string).
  std::array<std::string, 128> rule;
  std::array<bool, 128> has_rule{};

  void set(char symbol, const std::string& replacement);
};

// Symbols after `iterations` rewrites of `axiom`, and the largest length of any intermediate
// string, both saturating at `cap` + 1 so that absurd growth is reported without overflow.
struct LSystemLength {
  std::uint64_t final_length = 0;
  std::uint64_t peak_length = 0;
};
LSystemLength lsystem_length(const std::string& axiom, const LSystemRules& rules, int iterations,
                             std::uint64_t cap);

// Largest max_length lsystem_expand accepts: expansion keeps two strings of the peak length, so
// 2³⁰ symbols is already 2 GiB; a cloud holds far fewer spheres than that anyway.
constexpr std::uint64_t kMaxLSystemLength = std::uint64_t{1} << 30;

// The expanded string. Throws std::invalid_argument (before allocating anything large) when the
// final or any intermediate string would exceed max_length symbols, or max_length exceeds
// kMaxLSystemLength.
std::string lsystem_expand(const std::string& axiom, const LSystemRules& rules, int iterations,
                           std::uint64_t max_length);

struct TurtleParams {
  double angle_lo = 25.0, angle_hi = 25.0;  // δ, degrees
  double radius_lo = 0.6, radius_hi = 1.0;
  double step_lo = 0.8, step_hi = 1.2;  // in units of the placed radius
  std::string draw_symbols = "XY";
  std::string move_symbols = "f";
  glm::dvec3 start{0.0};
  glm::dvec3 heading{1.0, 0.0, 0.0};
  glm::dvec3 up{0.0, 1.0, 0.0};
  std::uint64_t seed = 0;
  std::uint64_t max_spheres = 1u << 20;

  void validate() const;  // throws std::invalid_argument naming the bad parameter
};

struct TurtleResult {
  std::vector<glm::vec3> centres;
  std::vector<float> radii;
  int turns = 0;
  int moves = 0;      // move-only advances
  int max_depth = 0;  // deepest '[' nesting
  glm::dvec3 final_position{0.0};
  glm::dvec3 final_heading{0.0};
};

// Walk `symbols` with the turtle and place spheres.
TurtleResult lsystem_interpret(const std::string& symbols, const TurtleParams& params);

}  // namespace cumuli
