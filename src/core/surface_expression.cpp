#include "surface_expression.hpp"

#include "constrained_particles/core/limits.hpp"

#include "constrained_particles/core/surface.hpp"
#include "constrained_particles/core/types.hpp"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace constrained_particles
{
namespace
{
enum Op
{
  CONSTANT,
  VARIABLE_X,
  VARIABLE_Y,
  ADD,
  SUBTRACT,
  MULTIPLY,
  DIVIDE,
  POWER,
  NEGATE,
  SIN,
  COS,
  TAN,
  EXP,
  LOG,
  SQRT,
  TANH,
  ABS,
};

const struct
{
  const char* name;
  Op op;
} FUNCTIONS[] = { { "sin", SIN }, { "cos", COS },   { "tan", TAN },   { "exp", EXP },
                  { "log", LOG }, { "sqrt", SQRT }, { "tanh", TANH }, { "abs", ABS } };

/// Value, first and second derivatives with respect to x and y.
struct Jet
{
  double v = 0, x = 0, y = 0, xx = 0, xy = 0, yy = 0;
};

// f(u) with f' = d1 and f'' = d2 at u.v: chain rule to second order
Jet apply(const Jet& u, double f, double d1, double d2)
{
  return { f,
           d1 * u.x,
           d1 * u.y,
           d2 * u.x * u.x + d1 * u.xx,
           d2 * u.x * u.y + d1 * u.xy,
           d2 * u.y * u.y + d1 * u.yy };
}

Jet multiply(const Jet& a, const Jet& b)
{
  return { a.v * b.v,
           a.x * b.v + a.v * b.x,
           a.y * b.v + a.v * b.y,
           a.xx * b.v + 2 * a.x * b.x + a.v * b.xx,
           a.xy * b.v + a.x * b.y + a.y * b.x + a.v * b.xy,
           a.yy * b.v + 2 * a.y * b.y + a.v * b.yy };
}

Jet combine(const Jet& a, const Jet& b, double sign)
{
  return { a.v + sign * b.v,   a.x + sign * b.x,   a.y + sign * b.y,
           a.xx + sign * b.xx, a.xy + sign * b.xy, a.yy + sign * b.yy };
}

class Parser
{
public:
  Parser(const std::string& text, const std::string& field,
         std::vector<SurfaceExpression::Node>& nodes)
    : text_(text), field_(field), nodes_(nodes)
  {
  }

  int parseAll()
  {
    const int root = expression();
    skipSpace();
    if (position_ < text_.size())
      fail("expected an operator or the end of the formula");
    return root;
  }

private:
  [[noreturn]] void fail(const std::string& what) const
  {
    // control characters would cut or garble the message: show them as their code
    auto printable = [](char c)
    {
      const auto code = static_cast<unsigned char>(c);
      if (code >= 32 && code != 127)
        return std::string(1, c);
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02x", code);
      return std::string(escaped);
    };
    std::string shown;
    for (char c : text_)
      shown += printable(c);
    const std::string found =
        position_ < text_.size() ? "'" + printable(text_[position_]) + "'" : "the end";
    throw InvalidInput(field_, "= '" + shown + "': at position " + std::to_string(position_ + 1) +
                                   ", " + what + ", found " + found);
  }

  void skipSpace()
  {
    while (position_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[position_])))
      ++position_;
  }

  bool accept(char c)
  {
    skipSpace();
    if (position_ < text_.size() && text_[position_] == c)
    {
      ++position_;
      return true;
    }
    return false;
  }

  int add(int op, int left = -1, int right = -1, double value = 0)
  {
    nodes_.push_back(SurfaceExpression::Node{ op, left, right, value });
    return static_cast<int>(nodes_.size()) - 1;
  }

  int expression()
  {
    int left = term();
    for (;;)
    {
      if (accept('+'))
        left = add(ADD, left, term());
      else if (accept('-'))
        left = add(SUBTRACT, left, term());
      else
        return left;
    }
  }

  int term()
  {
    int left = factor();
    for (;;)
    {
      if (accept('*'))
        left = add(MULTIPLY, left, factor());
      else if (accept('/'))
        left = add(DIVIDE, left, factor());
      else
        return left;
    }
  }

  // a sign binds looser than '^' (-x^2 = -(x^2)) but may start an exponent (2^-x)
  int factor()
  {
    if (accept('-'))
      return add(NEGATE, factor());
    if (accept('+'))
      return factor();
    return power();
  }

  int power()
  {
    const int base = primary();
    if (accept('^'))
      return add(POWER, base, factor());  // right-associative
    return base;
  }

  int primary()
  {
    skipSpace();
    if (position_ >= text_.size())
      fail("expected a number, x, y, a function or '('");
    const char c = text_[position_];
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '.')
    {
      const char* start = text_.c_str() + position_;
      char* end = nullptr;
      const double value = std::strtod(start, &end);
      if (end == start)
        fail("expected a number");
      position_ += static_cast<std::size_t>(end - start);
      return add(CONSTANT, -1, -1, value);
    }
    if (accept('('))
    {
      const int inner = expression();
      if (!accept(')'))
        fail("expected ')'");
      return inner;
    }
    if (std::isalpha(static_cast<unsigned char>(c)))
    {
      const std::size_t start = position_;
      while (position_ < text_.size() && std::isalnum(static_cast<unsigned char>(text_[position_])))
        ++position_;
      const std::string name = text_.substr(start, position_ - start);
      if (name == "x")
        return add(VARIABLE_X);
      if (name == "y")
        return add(VARIABLE_Y);
      if (name == "pi")
        return add(CONSTANT, -1, -1, M_PI);
      if (name == "e")
        return add(CONSTANT, -1, -1, M_E);
      for (const auto& function : FUNCTIONS)
        if (name == function.name)
        {
          if (!accept('('))
            fail("expected '(' after " + name);
          const int argument = expression();
          if (!accept(')'))
            fail("expected ')'");
          return add(function.op, argument);
        }
      position_ = start;
      fail("unknown name '" + name +
           "' (variables: x, y; constants: pi, e; functions: sin, cos, "
           "tan, exp, log, sqrt, tanh, abs)");
    }
    fail("expected a number, x, y, a function or '('");
  }

  const std::string& text_;
  const std::string& field_;
  std::vector<SurfaceExpression::Node>& nodes_;
  std::size_t position_ = 0;
};

Jet evaluateNode(const std::vector<SurfaceExpression::Node>& nodes, int index, double x, double y)
{
  const SurfaceExpression::Node& node = nodes[index];
  switch (node.op)
  {
    case CONSTANT:
      return { node.value };
    case VARIABLE_X:
      return { x, 1.0 };
    case VARIABLE_Y:
      return { y, 0.0, 1.0 };
    default:
      break;
  }
  const Jet u = evaluateNode(nodes, node.left, x, y);
  switch (node.op)
  {
    case ADD:
      return combine(u, evaluateNode(nodes, node.right, x, y), 1.0);
    case SUBTRACT:
      return combine(u, evaluateNode(nodes, node.right, x, y), -1.0);
    case MULTIPLY:
      return multiply(u, evaluateNode(nodes, node.right, x, y));
    case DIVIDE:
    {
      // u / w = u * (1 / w); (1/t)' = -1/t^2, (1/t)'' = 2/t^3
      const Jet w = evaluateNode(nodes, node.right, x, y);
      const double inverse = 1.0 / w.v;
      return multiply(u, apply(w, inverse, -inverse * inverse, 2 * inverse * inverse * inverse));
    }
    case POWER:
    {
      const SurfaceExpression::Node& exponent = nodes[node.right];
      if (exponent.op == CONSTANT)  // t^n: works for negative bases too
      {
        const double n = exponent.value;
        return apply(u, std::pow(u.v, n), n * std::pow(u.v, n - 1),
                     n * (n - 1) * std::pow(u.v, n - 2));
      }
      // u^w = exp(w log u)
      const Jet w = evaluateNode(nodes, node.right, x, y);
      const Jet log_u = apply(u, std::log(u.v), 1.0 / u.v, -1.0 / (u.v * u.v));
      const Jet product = multiply(w, log_u);
      const double value = std::exp(product.v);
      return apply(product, value, value, value);
    }
    case NEGATE:
      return { -u.v, -u.x, -u.y, -u.xx, -u.xy, -u.yy };
    case SIN:
      return apply(u, std::sin(u.v), std::cos(u.v), -std::sin(u.v));
    case COS:
      return apply(u, std::cos(u.v), -std::sin(u.v), -std::cos(u.v));
    case TAN:
    {
      const double t = std::tan(u.v), sec2 = 1 + t * t;
      return apply(u, t, sec2, 2 * t * sec2);
    }
    case EXP:
    {
      const double value = std::exp(u.v);
      return apply(u, value, value, value);
    }
    case LOG:
      return apply(u, std::log(u.v), 1.0 / u.v, -1.0 / (u.v * u.v));
    case SQRT:
    {
      const double root = std::sqrt(u.v);
      return apply(u, root, 0.5 / root, -0.25 / (root * u.v));
    }
    case TANH:
    {
      const double t = std::tanh(u.v), sech2 = 1 - t * t;
      return apply(u, t, sech2, -2 * t * sech2);
    }
    case ABS:
      return apply(u, std::abs(u.v), u.v < 0 ? -1.0 : 1.0, 0.0);
  }
  return {};
}

}  // namespace

std::shared_ptr<const SurfaceExpression> SurfaceExpression::parse(const std::string& formula,
                                                                  const std::string& field)
{
  if (formula.size() > limits::FORMULA_LENGTH)
    throw InvalidInput(field, "has " + std::to_string(formula.size()) +
                                  " characters, must have at most " +
                                  std::to_string(limits::FORMULA_LENGTH));
  auto expression = std::make_shared<SurfaceExpression>();
  expression->formula_ = formula;
  Parser parser(expression->formula_, field, expression->nodes_);
  expression->root_ = parser.parseAll();
  return expression;
}

SurfaceSample SurfaceExpression::evaluate(double x, double y) const
{
  const Jet z = evaluateNode(nodes_, root_, x, y);
  SurfaceSample s;
  s.z = z.v;
  s.zx = z.x;
  s.zy = z.y;
  s.zxx = z.xx;
  s.zxy = z.xy;
  s.zyy = z.yy;
  return s;
}

}  // namespace constrained_particles
