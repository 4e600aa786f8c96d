#include "cumuli/model/lsystem.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include <glm/geometric.hpp>

#include "cumuli/rng.hpp"

namespace cumuli {

namespace {

// Rewrites beyond this are refused: growth that is only linear (X → XA) would otherwise let the
// length count run for as many iterations as asked.
constexpr int kMaxIterations = 100000;
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

std::uint64_t sat_add(std::uint64_t a, std::uint64_t b, std::uint64_t limit) {
  return (a > limit || b > limit - a) ? limit : a + b;
}

void require_ascii(const std::string& s, const char* name) {
  for (unsigned char c : s)
    if (c >= 128) throw std::invalid_argument(std::string(name) + " must be ASCII");
}

// Rotate v about unit axis a by angle t (Rodrigues).
glm::dvec3 rotate(glm::dvec3 v, glm::dvec3 a, double t) {
  const double c = std::cos(t), s = std::sin(t);
  return v * c + glm::cross(a, v) * s + a * glm::dot(a, v) * (1.0 - c);
}

struct Frame {
  glm::dvec3 pos;
  glm::dvec3 h, u;  // heading and up; left is u × h
};

// Gram–Schmidt: keeps the frame orthonormal over thousands of turns.
void reorthonormalise(Frame& f) {
  f.h = glm::normalize(f.h);
  f.u = glm::normalize(f.u - f.h * glm::dot(f.u, f.h));
}

}  // namespace

void LSystemRules::set(char symbol, const std::string& replacement) {
  const unsigned char c = static_cast<unsigned char>(symbol);
  if (c >= 128) throw std::invalid_argument("rules: symbols must be ASCII");
  require_ascii(replacement, "rules");
  rule[c] = replacement;
  has_rule[c] = true;
}

LSystemLength lsystem_length(const std::string& axiom, const LSystemRules& rules, int iterations,
                             std::uint64_t cap) {
  if (iterations < 0 || iterations > kMaxIterations)
    throw std::invalid_argument("iterations must be in [0, " + std::to_string(kMaxIterations) +
                                "]");
  require_ascii(axiom, "axiom");
  const std::uint64_t limit = cap + 1;  // saturate here
  // len[c] = length of symbol c after k rewrites; start with k = 0.
  std::array<std::uint64_t, 128> len;
  len.fill(1);
  auto total = [&] {
    std::uint64_t t = 0;
    for (unsigned char c : axiom) t = sat_add(t, len[c], limit);
    return t;
  };
  LSystemLength out;
  out.final_length = out.peak_length = total();
  for (int k = 0; k < iterations; ++k) {
    std::array<std::uint64_t, 128> next;
    for (int c = 0; c < 128; ++c) {
      if (!rules.has_rule[c]) {
        next[c] = 1;
        continue;
      }
      std::uint64_t t = 0;
      for (unsigned char d : rules.rule[c]) t = sat_add(t, len[d], limit);
      next[c] = t;
    }
    if (next == len) break;  // a fixed point: further iterations change nothing in length
    len = next;
    out.final_length = total();
    out.peak_length = std::max(out.peak_length, out.final_length);
  }
  return out;
}

std::string lsystem_expand(const std::string& axiom, const LSystemRules& rules, int iterations,
                           std::uint64_t max_length) {
  // A user cap beyond this would let `reserve` ask for terabytes (or be overcommitted and filled
  // until the OOM killer strikes): refuse it rather than trust it.
  if (max_length > kMaxLSystemLength)
    throw std::invalid_argument("max_length must be at most " + std::to_string(kMaxLSystemLength) +
                                ", got " + std::to_string(max_length));
  const LSystemLength n = lsystem_length(axiom, rules, iterations, max_length);
  if (n.peak_length > max_length) {
    // Count again without the cap (saturating only at 2⁶⁴) to say how long it would be.
    const LSystemLength exact = lsystem_length(axiom, rules, iterations, UINT64_MAX - 1);
    const bool final_too_long = n.final_length > max_length;
    const std::uint64_t shown = final_too_long ? exact.final_length : exact.peak_length;
    throw std::invalid_argument(
        std::string(final_too_long ? "the expansion" : "an intermediate string of the expansion") +
        " would have " +
        (shown >= UINT64_MAX ? std::string("more than 2^64") : std::to_string(shown)) +
        " symbols, more than max_length " + std::to_string(max_length) +
        "; lower iterations or raise max_length");
  }
  std::string cur = axiom, next;
  for (int k = 0; k < iterations; ++k) {
    next.clear();
    next.reserve(static_cast<std::size_t>(n.peak_length));
    bool changed = false;
    for (unsigned char c : cur) {
      if (c < 128 && rules.has_rule[c]) {
        next += rules.rule[c];
        changed = true;
      } else {
        next += static_cast<char>(c);
      }
    }
    cur.swap(next);
    if (!changed) break;
  }
  return cur;
}

void TurtleParams::validate() const {
  auto finite = [](double v) { return std::isfinite(v); };
  if (!(finite(angle_lo) && finite(angle_hi) && angle_lo <= angle_hi))
    throw std::invalid_argument("angle must be finite with lo <= hi");
  if (!(finite(radius_lo) && finite(radius_hi) && radius_lo > 0.0 && radius_lo <= radius_hi))
    throw std::invalid_argument("radius must satisfy 0 < lo <= hi");
  if (!(finite(step_lo) && finite(step_hi) && step_lo >= 0.0 && step_lo <= step_hi))
    throw std::invalid_argument("step must satisfy 0 <= lo <= hi");
  for (int k = 0; k < 3; ++k)
    if (!finite(start[k]) || !finite(heading[k]) || !finite(up[k]))
      throw std::invalid_argument("start, heading and up must be finite");
  const double hl = glm::length(heading), ul = glm::length(up);
  if (hl < 1e-12) throw std::invalid_argument("heading must not be the zero vector");
  if (ul < 1e-12) throw std::invalid_argument("up must not be the zero vector");
  if (glm::length(glm::cross(heading / hl, up / ul)) < 1e-6)
    throw std::invalid_argument("heading and up must not be parallel");
  require_ascii(draw_symbols, "draw_symbols");
  require_ascii(move_symbols, "move_symbols");
  for (char c : draw_symbols)
    if (move_symbols.find(c) != std::string::npos)
      throw std::invalid_argument(std::string("symbol '") + c +
                                  "' is in both draw_symbols and move_symbols");
}

TurtleResult lsystem_interpret(const std::string& symbols, const TurtleParams& p) {
  p.validate();
  std::array<bool, 256> draws{}, moves{};
  for (unsigned char c : p.draw_symbols) draws[c] = true;
  for (unsigned char c : p.move_symbols) moves[c] = true;
  std::uint64_t count = 0;
  for (unsigned char c : symbols) count += draws[c] ? 1 : 0;
  if (count > p.max_spheres)
    throw std::invalid_argument("the string places " + std::to_string(count) +
                                " spheres, more than the limit " + std::to_string(p.max_spheres));
  TurtleResult out;
  out.centres.reserve(static_cast<std::size_t>(count));
  out.radii.reserve(static_cast<std::size_t>(count));
  Rng rng(p.seed);
  Frame f{p.start, p.heading, p.up};
  reorthonormalise(f);
  std::vector<Frame> stack;
  auto turn = [&](glm::dvec3 axis, double sign) {
    const double delta = rng.uniform(p.angle_lo, p.angle_hi) * kDegToRad * sign;
    f.h = rotate(f.h, axis, delta);
    f.u = rotate(f.u, axis, delta);
    reorthonormalise(f);
    ++out.turns;
  };
  for (std::size_t i = 0; i < symbols.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(symbols[i]);
    const glm::dvec3 left = glm::cross(f.u, f.h);
    if (draws[c] || moves[c]) {
      const double r = rng.uniform(p.radius_lo, p.radius_hi);
      const double s = rng.uniform(p.step_lo, p.step_hi);
      if (draws[c]) {
        out.centres.emplace_back(f.pos);
        out.radii.push_back(static_cast<float>(r));
      } else {
        ++out.moves;
      }
      f.pos += f.h * (r * s);
      continue;
    }
    switch (c) {
      case '+':
        turn(f.u, +1.0);
        break;
      case '-':
        turn(f.u, -1.0);
        break;
      case '&':
        turn(left, +1.0);
        break;
      case '^':
        turn(left, -1.0);
        break;
      case '\\':
        turn(f.h, -1.0);
        break;
      case '/':
        turn(f.h, +1.0);
        break;
      case '|':
        f.h = -f.h;  // 180° about U: heading reverses, up stays
        ++out.turns;
        break;
      case '[':
        stack.push_back(f);
        out.max_depth = std::max(out.max_depth, static_cast<int>(stack.size()));
        break;
      case ']':
        if (stack.empty())
          throw std::invalid_argument("unbalanced ']' at position " + std::to_string(i) +
                                      " of the expanded string");
        f = stack.back();
        stack.pop_back();
        break;
      default:
        break;  // symbols without a turtle meaning (e.g. rule-only variables) are skipped
    }
  }
  for (const auto& c : out.centres)
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(c[k]))
        throw std::invalid_argument("turtle left the float range (start/step too large)");
  out.final_position = f.pos;
  out.final_heading = f.h;
  return out;
}

}  // namespace cumuli
