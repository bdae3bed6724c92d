/// @file surface_expression.hpp
/// @brief Height fields given as a formula Z(x, y), differentiated automatically.
///
/// Grammar (whitespace ignored):
///   expression := term (('+' | '-') term)*
///   term       := factor (('*' | '/') factor)*
///   factor     := ('-' | '+') factor | power      (so -x^2 = -(x^2))
///   power      := primary ('^' factor)?           (right-associative; 2^-x allowed)
///   primary    := number | 'x' | 'y' | 'pi' | 'e' | function '(' expression ')' | '(' expression
///   ')' function   := sin cos tan exp log sqrt tanh abs
/// Gradient and Hessian come from second-order forward-mode automatic differentiation (a jet of
/// value, 2 first and 3 second derivatives), exact to round-off; no finite differences.
#pragma once

#include <memory>
#include <string>
#include <vector>

namespace constrained_particles
{
struct SurfaceSample;

/// A parsed formula. Immutable; evaluation is thread-safe and allocates nothing.
class SurfaceExpression
{
public:
  /// Parses `formula`. @throws InvalidInput naming `field`, the character position (from 1) and
  /// what was expected there.
  static std::shared_ptr<const SurfaceExpression> parse(const std::string& formula,
                                                        const std::string& field = "expression");

  /// Z, gradient and Hessian at (x, y) [m].
  SurfaceSample evaluate(double x, double y) const;

  const std::string& formula() const
  {
    return formula_;
  }

  /// One node of the parsed tree (public for the evaluator; not an API).
  struct Node
  {
    int op;         ///< operation code
    int left = -1;  ///< operand node indices
    int right = -1;
    double value = 0;  ///< constant
  };

private:
  std::string formula_;
  std::vector<Node> nodes_;
  int root_ = -1;
};

}  // namespace constrained_particles
