//! User expressions in x, y (z) for boundary selectors, data and gaps (docs/design.md §7).
//!
//! An [`Expr`] is parsed once from the scene file and evaluated at many points. It keeps its
//! source text (for messages and reports) and a compiled tree in which every constant
//! sub-expression has been folded, so a plain number such as `"-0.01"` or `"2*pi"` is stored
//! as a single constant ([`Expr::is_constant`]).
//!
//! # Why not exmex
//!
//! The parser is a small recursive-descent parser written here rather than `exmex` 0.21,
//! because exmex gives answers that are wrong for physics formulas and cannot be configured
//! around them: unary operators bind tighter than every binary operator (`-x^2` = x², so
//! `exp(-x^2)` grows instead of decaying), `2^3^2` = 64, scientific notation (`1e-3`) is not a
//! number, and `max(0, min(x, y))` fails with "parentheses mismatch".
//!
//! # Grammar
//!
//! From the loosest to the tightest binding:
//!
//! | level | operators | notes |
//! |---|---|---|
//! | or | `a \|\| b` | 1 if either operand is true, else 0 |
//! | and | `a && b` | 1 if both operands are true, else 0 |
//! | comparison | `<` `>` `<=` `>=` | 1 (true) or 0 (false); chains like `0.2 < x < 0.8` mean `0.2 < x && x < 0.8` |
//! | additive | `+` `-` | left associative |
//! | multiplicative | `*` `/` | left associative |
//! | prefix | `-a` `+a` `!a` | `!a` is 1 if `a` is false, else 0 |
//! | power | `a ^ b` | **right** associative, tighter than prefix minus |
//!
//! So `-2^2` = −4 and `2^3^2` = 2^9 = 512, as in mathematics (and Python, Fortran); the
//! exponent may carry its own sign: `2^-1` = 0.5. A value is *true* when it is > 0 (NaN is
//! false), the convention of the selectors in docs/design.md §7 (`where = "y > 0.999"`).
//! Equality (`==`, `!=`) is deliberately absent: mesh coordinates are rarely exact, so the
//! message suggests `abs(x - 1) < 1e-9` instead.
//!
//! Numbers: `2`, `2.`, `.5`, `1.5e-3`. Variables: `x`, `y`, `z` (anything else is an error
//! naming the variable). Constants: `pi` (also `π`), `e`. Functions: see [`FUNCTIONS`]; `log` is
//! the natural logarithm, `min` and `max` take two or more arguments.

use std::fmt;
use std::str::FromStr;

/// Deepest compiled tree accepted (e.g. a chain of 256 additions). Keeps evaluation and
/// dropping far from any stack limit, also on worker threads with small stacks.
const MAX_DEPTH: usize = 256;

/// Deepest nesting of parentheses, function calls and prefix operators accepted while parsing
/// (each level costs several stack frames of the recursive-descent parser).
const MAX_NESTING: usize = 64;

/// Most nodes of a compiled tree (after constant folding): an evaluation costs at most this
/// many operations, so the cost of an expression over a mesh is bounded by this times the
/// number of evaluation points. Scene expressions have a few dozen nodes.
pub const MAX_NODES: usize = 10_000;

/// Most tokens of an expression's text (bounds the parser's time and memory before folding).
pub const MAX_TOKENS: usize = 1_000_000;

/// A parsed user expression in x, y, z.
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    source: String,
    node: Node,
}

/// Parses `src` (see the [module documentation](self) for the grammar).
///
/// The error is one line, e.g. `unknown variable 'q'` or `expected ')' at column 7, found 'y'`.
pub fn parse(src: &str) -> Result<Expr, String> {
    Expr::parse(src)
}

impl Expr {
    /// Parses `src`; see [`parse`].
    pub fn parse(src: &str) -> Result<Expr, String> {
        let tokens = lex(src)?;
        let mut parser = Parser {
            tokens: &tokens,
            pos: 0,
            depth: 0,
        };
        let tree = parser.parse_or()?;
        let nodes = tree.node.count();
        if nodes > MAX_NODES {
            return Err(format!(
                "expression too large ({nodes} nodes after constant folding, limit {MAX_NODES})"
            ));
        }
        match parser.peek() {
            Tok::End => {}
            Tok::Comma => {
                return Err(format!(
                    "unexpected ',' at column {} (commas only separate function arguments)",
                    parser.column()
                ));
            }
            Tok::Close => {
                return Err(format!("unmatched ')' at column {}", parser.column()));
            }
            _ => return Err(parser.missing_operator()),
        }
        Ok(Expr {
            source: src.to_string(),
            node: tree.node,
        })
    }

    /// The constant expression `v` (its source text is `v` printed so that it reads back
    /// exactly).
    pub fn constant(v: f64) -> Expr {
        Expr {
            source: format!("{v:?}"),
            node: Node::Num(v),
        }
    }

    /// The value at the point (x, y, z).
    #[inline]
    pub fn eval(&self, x: f64, y: f64, z: f64) -> f64 {
        match &self.node {
            Node::Num(v) => *v,
            node => node.eval(&[x, y, z]),
        }
    }

    /// The value at (x, y, z) when it is finite; otherwise an error naming the expression, the
    /// point and the value, e.g. `"1/x" is infinite at (x, y) = (0, 0.5)`.
    pub fn eval_finite(&self, x: f64, y: f64, z: f64) -> Result<f64, String> {
        let v = self.eval(x, y, z);
        if v.is_finite() {
            return Ok(v);
        }
        let what = if v.is_nan() {
            "not a number (NaN)"
        } else {
            "infinite"
        };
        let at = if z == 0.0 {
            format!("(x, y) = ({x:?}, {y:?})")
        } else {
            format!("(x, y, z) = ({x:?}, {y:?}, {z:?})")
        };
        Err(format!(
            "expression {} is {what} at {at}",
            crate::error::quote(&self.source)
        ))
    }

    /// The value and the gradient (∂/∂x, ∂/∂y) at (x, y, 0), by forward-mode differentiation
    /// of the compiled tree: exact to rounding wherever the expression is differentiable.
    /// Piecewise-constant parts (comparisons, `floor`, `ceil`, `sign`) have gradient 0; `abs`,
    /// `min` and `max` take the one-sided derivative of the branch chosen, `a^b` at a = 0
    /// the limit b·a^(b−1)·∇a of a constant exponent. The Dirichlet lifting of the error
    /// bound needs the tangential derivative of the data (docs/design.md §6.2).
    pub fn eval_gradient(&self, x: f64, y: f64) -> (f64, [f64; 2]) {
        self.node.dual(&[x, y, 0.0])
    }

    /// Number of nodes of the compiled tree (1 for a constant): the cost of one evaluation.
    pub fn node_count(&self) -> usize {
        self.node.count()
    }

    /// Whether the expression is true at (x, y, z), i.e. its value is > 0 (NaN is false).
    #[inline]
    pub fn holds(&self, x: f64, y: f64, z: f64) -> bool {
        self.eval(x, y, z) > 0.0
    }

    /// Whether the expression does not depend on x, y, z (after constant folding).
    pub fn is_constant(&self) -> bool {
        matches!(self.node, Node::Num(_))
    }

    /// The value if the expression is constant.
    pub fn constant_value(&self) -> Option<f64> {
        match self.node {
            Node::Num(v) => Some(v),
            _ => None,
        }
    }

    /// The source text as written by the user.
    pub fn source(&self) -> &str {
        &self.source
    }
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.source)
    }
}

impl FromStr for Expr {
    type Err = String;
    fn from_str(s: &str) -> Result<Expr, String> {
        Expr::parse(s)
    }
}

// ---------------------------------------------------------------------------------------------
// Compiled tree

#[derive(Clone, Copy, Debug, PartialEq)]
enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Lt,
    Gt,
    Le,
    Ge,
    And,
    Or,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum UnOp {
    Neg,
    Not,
}

/// The functions accepted in expressions, by name. `min` and `max` take two or more
/// arguments, `atan2(y, x)` and `hypot(a, b)` two, all others one.
pub const FUNCTIONS: &[&str] = &[
    "abs", "acos", "asin", "atan", "atan2", "ceil", "cos", "cosh", "exp", "floor", "hypot", "ln",
    "log", "log10", "max", "min", "sign", "sin", "sinh", "sqrt", "tan", "tanh",
];

#[derive(Clone, Copy, Debug, PartialEq)]
enum Func {
    Abs,
    Acos,
    Asin,
    Atan,
    Atan2,
    Ceil,
    Cos,
    Cosh,
    Exp,
    Floor,
    Hypot,
    Ln,
    Log10,
    Max,
    Min,
    Sign,
    Sin,
    Sinh,
    Sqrt,
    Tan,
    Tanh,
}

/// How many arguments a function takes.
#[derive(Clone, Copy)]
enum Arity {
    Exactly(usize),
    AtLeast(usize),
}

impl Func {
    fn by_name(name: &str) -> Option<Func> {
        Some(match name {
            "abs" => Func::Abs,
            "acos" => Func::Acos,
            "asin" => Func::Asin,
            "atan" => Func::Atan,
            "atan2" => Func::Atan2,
            "ceil" => Func::Ceil,
            "cos" => Func::Cos,
            "cosh" => Func::Cosh,
            "exp" => Func::Exp,
            "floor" => Func::Floor,
            "hypot" => Func::Hypot,
            "ln" | "log" => Func::Ln,
            "log10" => Func::Log10,
            "max" => Func::Max,
            "min" => Func::Min,
            "sign" => Func::Sign,
            "sin" => Func::Sin,
            "sinh" => Func::Sinh,
            "sqrt" => Func::Sqrt,
            "tan" => Func::Tan,
            "tanh" => Func::Tanh,
            _ => return None,
        })
    }

    fn arity(self) -> Arity {
        match self {
            Func::Min | Func::Max => Arity::AtLeast(2),
            Func::Atan2 | Func::Hypot => Arity::Exactly(2),
            _ => Arity::Exactly(1),
        }
    }

    fn apply1(self, a: f64) -> f64 {
        match self {
            Func::Abs => a.abs(),
            Func::Acos => a.acos(),
            Func::Asin => a.asin(),
            Func::Atan => a.atan(),
            Func::Ceil => a.ceil(),
            Func::Cos => a.cos(),
            Func::Cosh => a.cosh(),
            Func::Exp => a.exp(),
            Func::Floor => a.floor(),
            Func::Ln => a.ln(),
            Func::Log10 => a.log10(),
            // sign(0) = 0 (f64::signum would give 1), sign(NaN) = NaN.
            Func::Sign => {
                if a > 0.0 {
                    1.0
                } else if a < 0.0 {
                    -1.0
                } else {
                    a
                }
            }
            Func::Sin => a.sin(),
            Func::Sinh => a.sinh(),
            Func::Sqrt => a.sqrt(),
            Func::Tan => a.tan(),
            Func::Tanh => a.tanh(),
            Func::Atan2 | Func::Hypot | Func::Max | Func::Min => unreachable!("not unary"),
        }
    }

    fn apply(self, args: &[f64]) -> f64 {
        match self {
            Func::Atan2 => args[0].atan2(args[1]),
            Func::Hypot => args[0].hypot(args[1]),
            Func::Min => args.iter().copied().fold(f64::INFINITY, f64::min),
            Func::Max => args.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            _ => self.apply1(args[0]),
        }
    }
}

#[inline]
fn truth(b: bool) -> f64 {
    if b { 1.0 } else { 0.0 }
}

impl BinOp {
    #[inline]
    fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            BinOp::Add => a + b,
            BinOp::Sub => a - b,
            BinOp::Mul => a * b,
            BinOp::Div => a / b,
            BinOp::Pow => a.powf(b),
            BinOp::Lt => truth(a < b),
            BinOp::Gt => truth(a > b),
            BinOp::Le => truth(a <= b),
            BinOp::Ge => truth(a >= b),
            BinOp::And => truth(a > 0.0 && b > 0.0),
            BinOp::Or => truth(a > 0.0 || b > 0.0),
        }
    }
}

impl UnOp {
    #[inline]
    fn apply(self, a: f64) -> f64 {
        match self {
            UnOp::Neg => -a,
            UnOp::Not => truth(a <= 0.0 || a.is_nan()),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
enum Node {
    Num(f64),
    /// 0 = x, 1 = y, 2 = z.
    Var(usize),
    Unary(UnOp, Box<Node>),
    Binary(BinOp, Box<Node>, Box<Node>),
    Call1(Func, Box<Node>),
    Call(Func, Vec<Node>),
}

impl Node {
    fn eval(&self, p: &[f64; 3]) -> f64 {
        match self {
            Node::Num(v) => *v,
            Node::Var(i) => p[*i],
            Node::Unary(op, a) => op.apply(a.eval(p)),
            Node::Binary(BinOp::And, a, b) => truth(a.eval(p) > 0.0 && b.eval(p) > 0.0),
            Node::Binary(BinOp::Or, a, b) => truth(a.eval(p) > 0.0 || b.eval(p) > 0.0),
            Node::Binary(op, a, b) => op.apply(a.eval(p), b.eval(p)),
            Node::Call1(f, a) => f.apply1(a.eval(p)),
            Node::Call(f, args) => match f {
                Func::Min => args.iter().map(|a| a.eval(p)).fold(f64::INFINITY, f64::min),
                Func::Max => args
                    .iter()
                    .map(|a| a.eval(p))
                    .fold(f64::NEG_INFINITY, f64::max),
                _ => {
                    let values: Vec<f64> = args.iter().map(|a| a.eval(p)).collect();
                    f.apply(&values)
                }
            },
        }
    }

    /// (value, ∂/∂x, ∂/∂y): forward-mode differentiation (see [`Expr::eval_gradient`]).
    fn dual(&self, p: &[f64; 3]) -> (f64, [f64; 2]) {
        const Z: [f64; 2] = [0.0; 2];
        let scale = |k: f64, g: [f64; 2]| [k * g[0], k * g[1]];
        match self {
            Node::Num(v) => (*v, Z),
            Node::Var(i) => (
                p[*i],
                match i {
                    0 => [1.0, 0.0],
                    1 => [0.0, 1.0],
                    _ => Z,
                },
            ),
            Node::Unary(UnOp::Neg, a) => {
                let (v, g) = a.dual(p);
                (-v, scale(-1.0, g))
            }
            Node::Unary(op, a) => (op.apply(a.eval(p)), Z),
            Node::Binary(op, a, b) => {
                let ((u, gu), (v, gv)) = (a.dual(p), b.dual(p));
                let lin = |ka: f64, kb: f64| [ka * gu[0] + kb * gv[0], ka * gu[1] + kb * gv[1]];
                match op {
                    BinOp::Add => (u + v, lin(1.0, 1.0)),
                    BinOp::Sub => (u - v, lin(1.0, -1.0)),
                    BinOp::Mul => (u * v, lin(v, u)),
                    BinOp::Div => (u / v, lin(1.0 / v, -u / (v * v))),
                    BinOp::Pow => {
                        let w = u.powf(v);
                        // d(u^v) = v u^(v−1) du + u^v ln u dv; the second only when v varies.
                        let ku = if v == 0.0 { 0.0 } else { v * u.powf(v - 1.0) };
                        let kv = if gv == Z || w == 0.0 { 0.0 } else { w * u.ln() };
                        (w, lin(ku, kv))
                    }
                    _ => (op.apply(u, v), Z),
                }
            }
            Node::Call1(f, a) => {
                let (u, g) = a.dual(p);
                let k = match f {
                    Func::Abs => {
                        if u < 0.0 {
                            -1.0
                        } else {
                            1.0
                        }
                    }
                    Func::Acos => -1.0 / (1.0 - u * u).sqrt(),
                    Func::Asin => 1.0 / (1.0 - u * u).sqrt(),
                    Func::Atan => 1.0 / (1.0 + u * u),
                    Func::Ceil | Func::Floor | Func::Sign => 0.0,
                    Func::Cos => -u.sin(),
                    Func::Cosh => u.sinh(),
                    Func::Exp => u.exp(),
                    Func::Ln => 1.0 / u,
                    Func::Log10 => 1.0 / (u * std::f64::consts::LN_10),
                    Func::Sin => u.cos(),
                    Func::Sinh => u.cosh(),
                    Func::Sqrt => 0.5 / u.sqrt(),
                    Func::Tan => 1.0 + u.tan() * u.tan(),
                    Func::Tanh => 1.0 - u.tanh() * u.tanh(),
                    Func::Atan2 | Func::Hypot | Func::Max | Func::Min => unreachable!("not unary"),
                };
                (f.apply1(u), if k == 0.0 { Z } else { scale(k, g) })
            }
            Node::Call(f, args) => {
                let d: Vec<(f64, [f64; 2])> = args.iter().map(|a| a.dual(p)).collect();
                match f {
                    Func::Min | Func::Max => {
                        let better = |x: f64, y: f64| {
                            if matches!(f, Func::Min) { x < y } else { x > y }
                        };
                        let mut best = d[0];
                        for &c in &d[1..] {
                            if better(c.0, best.0) || c.0.is_nan() {
                                best = c;
                            }
                        }
                        best
                    }
                    Func::Atan2 => {
                        let ((y, gy), (x, gx)) = (d[0], d[1]);
                        let r2 = x * x + y * y;
                        (
                            y.atan2(x),
                            [(x * gy[0] - y * gx[0]) / r2, (x * gy[1] - y * gx[1]) / r2],
                        )
                    }
                    Func::Hypot => {
                        let ((a, ga), (b, gb)) = (d[0], d[1]);
                        let h = a.hypot(b);
                        (
                            h,
                            [(a * ga[0] + b * gb[0]) / h, (a * ga[1] + b * gb[1]) / h],
                        )
                    }
                    // Only min, max, atan2 and hypot are stored as `Call` (`Tree::call`).
                    _ => (self.eval(p), Z),
                }
            }
        }
    }

    fn num(&self) -> Option<f64> {
        match self {
            Node::Num(v) => Some(*v),
            _ => None,
        }
    }

    /// Nodes of the tree (its depth is bounded by [`MAX_DEPTH`], so recursion is safe).
    fn count(&self) -> usize {
        match self {
            Node::Num(_) | Node::Var(_) => 1,
            Node::Unary(_, a) | Node::Call1(_, a) => 1 + a.count(),
            Node::Binary(_, a, b) => 1 + a.count() + b.count(),
            Node::Call(_, args) => 1 + args.iter().map(Node::count).sum::<usize>(),
        }
    }
}

/// A sub-tree under construction with its depth (bounded by [`MAX_DEPTH`]).
struct Tree {
    node: Node,
    depth: usize,
}

fn too_deep() -> String {
    format!("expression nested too deeply (more than {MAX_DEPTH} levels)")
}

fn too_nested() -> String {
    format!("expression nested too deeply (more than {MAX_NESTING} parentheses or signs)")
}

impl Tree {
    fn leaf(node: Node) -> Tree {
        Tree { node, depth: 1 }
    }

    fn unary(op: UnOp, a: Tree) -> Result<Tree, String> {
        let depth = a.depth + 1;
        if depth > MAX_DEPTH {
            return Err(too_deep());
        }
        let node = match a.node.num() {
            Some(v) => Node::Num(op.apply(v)),
            None => Node::Unary(op, Box::new(a.node)),
        };
        Ok(Tree { node, depth })
    }

    fn binary(op: BinOp, a: Tree, b: Tree) -> Result<Tree, String> {
        let depth = a.depth.max(b.depth) + 1;
        if depth > MAX_DEPTH {
            return Err(too_deep());
        }
        let node = match (a.node.num(), b.node.num()) {
            (Some(u), Some(v)) => Node::Num(op.apply(u, v)),
            _ => Node::Binary(op, Box::new(a.node), Box::new(b.node)),
        };
        Ok(Tree { node, depth })
    }

    fn call(f: Func, args: Vec<Tree>) -> Result<Tree, String> {
        let depth = args.iter().map(|a| a.depth).max().unwrap_or(0) + 1;
        if depth > MAX_DEPTH {
            return Err(too_deep());
        }
        let nodes: Vec<Node> = args.into_iter().map(|a| a.node).collect();
        let values: Option<Vec<f64>> = nodes.iter().map(Node::num).collect();
        let node = match values {
            Some(values) => Node::Num(f.apply(&values)),
            None if nodes.len() == 1 && matches!(f.arity(), Arity::Exactly(1)) => {
                let mut nodes = nodes;
                Node::Call1(f, Box::new(nodes.pop().expect("one argument")))
            }
            None => Node::Call(f, nodes),
        };
        Ok(Tree { node, depth })
    }
}

// ---------------------------------------------------------------------------------------------
// Lexer

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Num(f64),
    Ident(String),
    Plus,
    Minus,
    Star,
    Slash,
    Caret,
    Lt,
    Gt,
    Le,
    Ge,
    AndAnd,
    OrOr,
    Bang,
    Open,
    Close,
    Comma,
    End,
}

struct Token {
    tok: Tok,
    /// 1-based column (in characters) of the first character.
    column: usize,
    /// The text of the token, for messages.
    text: String,
}

fn lex(src: &str) -> Result<Vec<Token>, String> {
    let chars: Vec<char> = src.chars().collect();
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let start = i;
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        let next = chars.get(i + 1).copied();
        let tok = if c.is_ascii_digit() || (c == '.' && next.is_some_and(|d| d.is_ascii_digit())) {
            while i < chars.len() && chars[i].is_ascii_digit() {
                i += 1;
            }
            if i < chars.len() && chars[i] == '.' {
                i += 1;
                while i < chars.len() && chars[i].is_ascii_digit() {
                    i += 1;
                }
            }
            // An exponent only when digits follow: `2e` is the number 2 and then `e`.
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < chars.len() && chars[j].is_ascii_digit() {
                    while j < chars.len() && chars[j].is_ascii_digit() {
                        j += 1;
                    }
                    i = j;
                }
            }
            let text: String = chars[start..i].iter().collect();
            let shown = crate::error::shorten(&text);
            let value: f64 = text
                .parse()
                .map_err(|_| format!("invalid number '{shown}' at column {}", start + 1))?;
            if !value.is_finite() {
                return Err(format!(
                    "number '{shown}' at column {} is out of range",
                    start + 1
                ));
            }
            Tok::Num(value)
        } else if c.is_alphabetic() || c == '_' {
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            Tok::Ident(chars[start..i].iter().collect())
        } else {
            i += 1;
            match (c, next) {
                ('<', Some('=')) => {
                    i += 1;
                    Tok::Le
                }
                ('>', Some('=')) => {
                    i += 1;
                    Tok::Ge
                }
                ('&', Some('&')) => {
                    i += 1;
                    Tok::AndAnd
                }
                ('|', Some('|')) => {
                    i += 1;
                    Tok::OrOr
                }
                ('=', Some('=')) | ('!', Some('=')) => {
                    return Err(format!(
                        "'{c}=' at column {} is not supported (coordinates are rarely exact): \
                         compare with a tolerance, e.g. abs(x - 1) < 1e-9",
                        start + 1
                    ));
                }
                ('=', _) => {
                    return Err(format!(
                        "'=' at column {} is not an operator: compare with <, >, <=, >=",
                        start + 1
                    ));
                }
                ('+', _) => Tok::Plus,
                ('-', _) => Tok::Minus,
                ('*', Some('*')) => {
                    return Err(format!(
                        "'**' at column {} is not an operator: write ^ for powers",
                        start + 1
                    ));
                }
                ('*', _) => Tok::Star,
                ('/', _) => Tok::Slash,
                ('^', _) => Tok::Caret,
                ('<', _) => Tok::Lt,
                ('>', _) => Tok::Gt,
                ('!', _) => Tok::Bang,
                ('(', _) => Tok::Open,
                (')', _) => Tok::Close,
                (',', _) => Tok::Comma,
                ('&', _) | ('|', _) => {
                    return Err(format!(
                        "'{c}' at column {} is not an operator: write {c}{c}",
                        start + 1
                    ));
                }
                _ => {
                    return Err(format!(
                        "unexpected character '{}' at column {}",
                        c.escape_debug(),
                        start + 1
                    ));
                }
            }
        };
        tokens.push(Token {
            tok,
            column: start + 1,
            text: chars[start..i].iter().collect(),
        });
        if tokens.len() > MAX_TOKENS {
            return Err(format!(
                "expression too long (more than {MAX_TOKENS} tokens)"
            ));
        }
    }
    if tokens.is_empty() {
        return Err("empty expression".to_string());
    }
    tokens.push(Token {
        tok: Tok::End,
        column: chars.len() + 1,
        text: String::new(),
    });
    Ok(tokens)
}

// ---------------------------------------------------------------------------------------------
// Parser

struct Parser<'a> {
    tokens: &'a [Token],
    pos: usize,
    /// Current recursion depth (parentheses, prefix operators, function arguments).
    depth: usize,
}

impl Parser<'_> {
    fn peek(&self) -> &Tok {
        &self.tokens[self.pos].tok
    }

    fn column(&self) -> usize {
        self.tokens[self.pos].column
    }

    fn advance(&mut self) -> &Token {
        let token = &self.tokens[self.pos];
        if token.tok != Tok::End {
            self.pos += 1;
        }
        token
    }

    /// Describes the current token for "expected …, found …" messages.
    fn found(&self) -> String {
        let token = &self.tokens[self.pos];
        match token.tok {
            Tok::End => "end of expression".to_string(),
            _ => format!(
                "'{}' at column {}",
                crate::error::shorten(&token.text),
                token.column
            ),
        }
    }

    /// Two operands in a row, e.g. `2 x` or `x (y)`.
    fn missing_operator(&self) -> String {
        format!("missing operator before {}", self.found())
    }

    fn enter(&mut self) -> Result<(), String> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            Err(too_nested())
        } else {
            Ok(())
        }
    }

    fn leave(&mut self) {
        self.depth -= 1;
    }

    fn parse_or(&mut self) -> Result<Tree, String> {
        self.enter()?;
        let mut left = self.parse_and()?;
        while *self.peek() == Tok::OrOr {
            self.advance();
            let right = self.parse_and()?;
            left = Tree::binary(BinOp::Or, left, right)?;
        }
        self.leave();
        Ok(left)
    }

    fn parse_and(&mut self) -> Result<Tree, String> {
        let mut left = self.parse_comparison()?;
        while *self.peek() == Tok::AndAnd {
            self.advance();
            let right = self.parse_comparison()?;
            left = Tree::binary(BinOp::And, left, right)?;
        }
        Ok(left)
    }

    /// `a < b`, and chains `a < b <= c` meaning `a < b && b <= c`.
    fn parse_comparison(&mut self) -> Result<Tree, String> {
        let first = self.parse_additive()?;
        let comparison = |tok: &Tok| match tok {
            Tok::Lt => Some(BinOp::Lt),
            Tok::Gt => Some(BinOp::Gt),
            Tok::Le => Some(BinOp::Le),
            Tok::Ge => Some(BinOp::Ge),
            _ => None,
        };
        let Some(mut op) = comparison(self.peek()) else {
            return Ok(first);
        };
        let mut result: Option<Tree> = None;
        let mut left = first;
        loop {
            self.advance();
            let right = self.parse_additive()?;
            let next = comparison(self.peek());
            // The middle operand of a chain is used twice.
            let right_copy = next.map(|_| Tree {
                node: right.node.clone(),
                depth: right.depth,
            });
            let test = Tree::binary(op, left, right)?;
            result = Some(match result {
                None => test,
                Some(previous) => Tree::binary(BinOp::And, previous, test)?,
            });
            match (next, right_copy) {
                (Some(next_op), Some(copy)) => {
                    op = next_op;
                    left = copy;
                }
                _ => break,
            }
        }
        Ok(result.expect("at least one comparison"))
    }

    fn parse_additive(&mut self) -> Result<Tree, String> {
        let mut left = self.parse_multiplicative()?;
        loop {
            let op = match self.peek() {
                Tok::Plus => BinOp::Add,
                Tok::Minus => BinOp::Sub,
                _ => return Ok(left),
            };
            self.advance();
            let right = self.parse_multiplicative()?;
            left = Tree::binary(op, left, right)?;
        }
    }

    fn parse_multiplicative(&mut self) -> Result<Tree, String> {
        let mut left = self.parse_prefix()?;
        loop {
            let op = match self.peek() {
                Tok::Star => BinOp::Mul,
                Tok::Slash => BinOp::Div,
                _ => return Ok(left),
            };
            self.advance();
            let right = self.parse_prefix()?;
            left = Tree::binary(op, left, right)?;
        }
    }

    /// Prefix `-`, `+`, `!`, binding looser than `^`: `-2^2` = −(2²).
    fn parse_prefix(&mut self) -> Result<Tree, String> {
        let op = match self.peek() {
            Tok::Minus => Some(UnOp::Neg),
            Tok::Bang => Some(UnOp::Not),
            Tok::Plus => None,
            _ => return self.parse_power(),
        };
        self.advance();
        self.enter()?;
        let operand = self.parse_prefix()?;
        self.leave();
        match op {
            Some(op) => Tree::unary(op, operand),
            None => Ok(operand),
        }
    }

    /// `a ^ b`, right associative; the exponent may have a sign: `2^-1`.
    fn parse_power(&mut self) -> Result<Tree, String> {
        let base = self.parse_primary()?;
        if *self.peek() != Tok::Caret {
            return Ok(base);
        }
        self.advance();
        self.enter()?;
        let exponent = self.parse_prefix()?;
        self.leave();
        Tree::binary(BinOp::Pow, base, exponent)
    }

    fn parse_primary(&mut self) -> Result<Tree, String> {
        let column = self.column();
        match self.peek().clone() {
            Tok::Num(v) => {
                self.advance();
                Ok(Tree::leaf(Node::Num(v)))
            }
            Tok::Open => {
                self.advance();
                let inner = self.parse_or()?;
                if *self.peek() != Tok::Close {
                    return Err(self.expected_close(column));
                }
                self.advance();
                Ok(inner)
            }
            Tok::Ident(name) => {
                self.advance();
                let call = *self.peek() == Tok::Open;
                if let Some(f) = Func::by_name(&name) {
                    if !call {
                        return Err(format!("function '{name}' needs parentheses: {name}(…)"));
                    }
                    return self.parse_call(&name, f);
                }
                let leaf = match name.as_str() {
                    "x" => Node::Var(0),
                    "y" => Node::Var(1),
                    "z" => Node::Var(2),
                    "pi" | "π" => Node::Num(std::f64::consts::PI),
                    "e" => Node::Num(std::f64::consts::E),
                    _ if call => {
                        return Err(format!(
                            "unknown function '{}' (known: {})",
                            crate::error::shorten(&name),
                            FUNCTIONS.join(", ")
                        ));
                    }
                    _ => {
                        return Err(format!(
                            "unknown variable '{}'",
                            crate::error::shorten(&name)
                        ));
                    }
                };
                if call {
                    return Err(format!("'{name}' is not a function"));
                }
                Ok(Tree::leaf(leaf))
            }
            Tok::End => Err(match self.tokens[..self.pos].last() {
                Some(previous) => format!(
                    "expected a value after '{}' at end of expression",
                    crate::error::shorten(&previous.text)
                ),
                None => "empty expression".to_string(),
            }),
            _ => Err(format!("expected a value, found {}", self.found())),
        }
    }

    /// After `name`, at `(`.
    fn parse_call(&mut self, name: &str, f: Func) -> Result<Tree, String> {
        let open_column = self.column();
        self.advance();
        self.enter()?;
        let mut args = Vec::new();
        if *self.peek() != Tok::Close {
            loop {
                args.push(self.parse_or()?);
                match self.peek() {
                    Tok::Comma => {
                        self.advance();
                    }
                    Tok::Close => break,
                    _ => return Err(self.expected_close(open_column)),
                }
            }
        }
        self.advance(); // ')'
        self.leave();
        let n = args.len();
        let plural = |k: usize| if k == 1 { "argument" } else { "arguments" };
        match f.arity() {
            Arity::Exactly(k) if n != k => {
                return Err(format!("{name} takes {k} {}, got {n}", plural(k)));
            }
            Arity::AtLeast(k) if n < k => {
                return Err(format!("{name} takes at least {k} {}, got {n}", plural(k)));
            }
            _ => {}
        }
        Tree::call(f, args)
    }

    fn expected_close(&self, open_column: usize) -> String {
        match self.peek() {
            Tok::End => format!("unclosed '(' at column {open_column}"),
            _ => format!("expected ')' or an operator, found {}", self.found()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{E, PI};

    fn ev(src: &str, x: f64, y: f64, z: f64) -> f64 {
        parse(src)
            .unwrap_or_else(|e| panic!("{src}: {e}"))
            .eval(x, y, z)
    }

    fn ev0(src: &str) -> f64 {
        ev(src, 0.0, 0.0, 0.0)
    }

    fn err(src: &str) -> String {
        parse(src).expect_err(src)
    }

    fn close(a: f64, b: f64) {
        assert!((a - b).abs() <= 1e-14 * b.abs().max(1.0), "{a} != {b}");
    }

    #[test]
    fn arithmetic_operators() {
        assert_eq!(ev0("1 + 2"), 3.0);
        assert_eq!(ev0("1 - 2"), -1.0);
        assert_eq!(ev0("3 * 4"), 12.0);
        assert_eq!(ev0("3 / 4"), 0.75);
        assert_eq!(ev0("2 ^ 10"), 1024.0);
        assert_eq!(ev0("-3"), -3.0);
        assert_eq!(ev0("+3"), 3.0);
        assert_eq!(ev0("--3"), 3.0);
        assert_eq!(ev0("(1 + 2) * 3"), 9.0);
        assert_eq!(ev0("1 + 2 * 3"), 7.0);
        assert_eq!(ev0("10 - 4 - 3"), 3.0); // left associative
        assert_eq!(ev0("2 / 4 / 5"), 0.1); // (2/4)/5
        assert_eq!(ev0("2 / 4 * 5"), 2.5); // (2/4)*5
        assert_eq!(ev0("1 - 2 + 3"), 2.0);
        assert_eq!(ev0("2 * -3"), -6.0);
    }

    #[test]
    fn numbers() {
        assert_eq!(ev0("2."), 2.0);
        assert_eq!(ev0(".5"), 0.5);
        assert_eq!(ev0("1.5e-3"), 0.0015);
        assert_eq!(ev0("1E3"), 1000.0);
        assert_eq!(ev0("2e+2"), 200.0);
        // `2e` is not an exponent: the number 2 followed by the constant e.
        assert_eq!(err("2e"), "missing operator before 'e' at column 2");
        assert_eq!(ev0("2*e"), 2.0 * E);
    }

    /// `-2^2` = −4 (prefix minus looser than `^`); `2^3^2` = 2^9 = 512 (right associative).
    #[test]
    fn precedence_of_power() {
        assert_eq!(ev0("-2^2"), -4.0);
        assert_eq!(ev0("2^3^2"), 512.0);
        assert_eq!(ev0("2^-1"), 0.5);
        assert_eq!(ev0("2^-1^2"), 0.5); // 2^(-(1^2))
        assert_eq!(ev0("(-2)^2"), 4.0);
        assert_eq!(ev("-x^2", 3.0, 0.0, 0.0), -9.0);
        close(ev("exp(-x^2)", 2.0, 0.0, 0.0), (-4.0f64).exp());
        assert_eq!(ev0("2 * 3 ^ 2"), 18.0);
        assert_eq!(ev0("-2 * 3"), -6.0);
    }

    #[test]
    fn variables() {
        assert_eq!(ev("x", 1.0, 2.0, 3.0), 1.0);
        assert_eq!(ev("y", 1.0, 2.0, 3.0), 2.0);
        assert_eq!(ev("z", 1.0, 2.0, 3.0), 3.0);
        assert_eq!(ev("-0.01*x + 2*y - z", 1.0, 2.0, 3.0), -0.01 + 4.0 - 3.0);
        assert_eq!(ev("x^2 + y^2", 3.0, 4.0, 0.0), 25.0);
    }

    #[test]
    fn functions_against_hand_values() {
        assert_eq!(ev0("sqrt(16)"), 4.0);
        assert_eq!(ev0("abs(-2.5)"), 2.5);
        close(ev0("sin(pi/6)"), 0.5);
        close(ev0("cos(pi/3)"), 0.5);
        close(ev0("tan(pi/4)"), 1.0);
        close(ev0("exp(1)"), E);
        close(ev0("log(e^3)"), 3.0); // natural logarithm
        close(ev0("ln(e)"), 1.0);
        close(ev0("log10(1000)"), 3.0);
        assert_eq!(ev0("min(3, -1)"), -1.0);
        assert_eq!(ev0("max(3, -1)"), 3.0);
        assert_eq!(ev0("min(4, 2, 3)"), 2.0);
        assert_eq!(ev0("max(0, min(5, 7))"), 5.0);
        assert_eq!(ev("max(min(x, y), 0)", 2.0, 3.0, 0.0), 2.0);
        assert_eq!(ev("max(0, min(x, (y+1)*2))", 9.0, 1.0, 0.0), 4.0);
        close(ev0("atan2(1, 1)"), PI / 4.0);
        assert_eq!(ev0("hypot(3, 4)"), 5.0);
        assert_eq!(ev0("sign(-3)"), -1.0);
        assert_eq!(ev0("sign(0)"), 0.0);
        assert_eq!(ev0("floor(2.7) + ceil(2.2)"), 5.0);
        close(ev0("asin(1)"), PI / 2.0);
        close(ev0("acos(1)"), 0.0);
        close(ev0("atan(1)"), PI / 4.0);
        close(ev0("cosh(0) + sinh(0) + tanh(0)"), 1.0);
        assert_eq!(ev0("pi"), PI);
        assert_eq!(ev0("π"), PI);
        assert_eq!(ev0("e"), E);
    }

    #[test]
    fn comparisons_are_one_or_zero() {
        assert_eq!(ev0("1 < 2"), 1.0);
        assert_eq!(ev0("2 < 1"), 0.0);
        assert_eq!(ev0("2 > 1"), 1.0);
        assert_eq!(ev0("1 > 1"), 0.0);
        assert_eq!(ev0("1 <= 1"), 1.0);
        assert_eq!(ev0("1 >= 2"), 0.0);
        assert_eq!(ev0("1 + 1 > 1"), 1.0); // arithmetic binds tighter
        assert_eq!(ev0("1 && 1"), 1.0);
        assert_eq!(ev0("1 && 0"), 0.0);
        assert_eq!(ev0("-1 || 0"), 0.0); // negative is false
        assert_eq!(ev0("0 || 2"), 1.0);
        assert_eq!(ev0("!0"), 1.0);
        assert_eq!(ev0("!3"), 0.0);
        assert_eq!(ev0("1 || 0 && 0"), 1.0); // && binds tighter than ||
    }

    #[test]
    fn selectors() {
        let top = parse("y > 0.999").unwrap();
        assert!(top.holds(0.3, 1.0, 0.0));
        assert!(!top.holds(0.3, 0.5, 0.0));
        let sides = parse("abs(x) > 0.999 && y < 0.5").unwrap();
        assert!(sides.holds(-1.0, 0.2, 0.0));
        assert!(!sides.holds(-1.0, 0.7, 0.0));
        assert!(!sides.holds(0.0, 0.2, 0.0));
        let band = parse("0.2 < x <= 0.8").unwrap();
        assert!(band.holds(0.5, 0.0, 0.0));
        assert!(band.holds(0.8, 0.0, 0.0));
        assert!(!band.holds(0.2, 0.0, 0.0));
        assert!(!band.holds(0.9, 0.0, 0.0));
        let either = parse("x < -0.999 || x > 0.999").unwrap();
        assert!(either.holds(1.0, 0.0, 0.0));
        assert!(either.holds(-1.0, 0.0, 0.0));
        assert!(!either.holds(0.0, 0.0, 0.0));
        // NaN is false.
        assert!(!parse("x").unwrap().holds(f64::NAN, 0.0, 0.0));
        assert!(!parse("x > 0").unwrap().holds(f64::NAN, 0.0, 0.0));
    }

    #[test]
    fn constants_are_folded() {
        assert!(parse("-0.01").unwrap().is_constant());
        assert_eq!(parse("-0.01").unwrap().constant_value(), Some(-0.01));
        assert!(parse("2*pi + sqrt(4)").unwrap().is_constant());
        assert!(!parse("0*x").unwrap().is_constant());
        let c = Expr::constant(-0.25);
        assert!(c.is_constant());
        assert_eq!(c.eval(1.0, 2.0, 3.0), -0.25);
        assert_eq!(c.source(), "-0.25");
        assert_eq!(Expr::constant(1e-7).source(), "1e-7");
        assert_eq!(parse(c.source()).unwrap(), c);
        let e = parse(" x + 1 ").unwrap();
        assert_eq!(e.source(), " x + 1 ");
        assert_eq!(e.to_string(), " x + 1 ");
        assert_eq!(" x + 1 ".parse::<Expr>().unwrap(), e);
    }

    #[test]
    fn error_messages() {
        assert_eq!(err("q + x"), "unknown variable 'q'");
        assert_eq!(err("X"), "unknown variable 'X'");
        assert_eq!(err(""), "empty expression");
        assert_eq!(err("   "), "empty expression");
        assert_eq!(
            err("x +"),
            "expected a value after '+' at end of expression"
        );
        assert_eq!(err("(x + 1"), "unclosed '(' at column 1");
        assert_eq!(err("x + 1)"), "unmatched ')' at column 6");
        assert_eq!(
            err("1, 2"),
            "unexpected ',' at column 2 (commas only separate function arguments)"
        );
        assert_eq!(err("2 x"), "missing operator before 'x' at column 3");
        assert_eq!(err("x * * y"), "expected a value, found '*' at column 5");
        assert_eq!(err("()"), "expected a value, found ')' at column 2");
        assert_eq!(err("x # 2"), "unexpected character '#' at column 3");
        assert_eq!(err("x\u{7}"), "unexpected character '\\u{7}' at column 2");
        assert_eq!(err("sin(x, y)"), "sin takes 1 argument, got 2");
        assert_eq!(err("atan2(x)"), "atan2 takes 2 arguments, got 1");
        assert_eq!(err("min(x)"), "min takes at least 2 arguments, got 1");
        assert_eq!(err("max()"), "max takes at least 2 arguments, got 0");
        assert_eq!(err("sin x"), "function 'sin' needs parentheses: sin(…)");
        assert_eq!(
            err("foo(x)"),
            format!("unknown function 'foo' (known: {})", FUNCTIONS.join(", "))
        );
        assert_eq!(err("x(2)"), "'x' is not a function");
        assert_eq!(err("pi(2)"), "'pi' is not a function");
        assert_eq!(
            err("min(x y)"),
            "expected ')' or an operator, found 'y' at column 7"
        );
        assert_eq!(err("min(x, y"), "unclosed '(' at column 4");
        assert_eq!(
            err("x = 1"),
            "'=' at column 3 is not an operator: compare with <, >, <=, >="
        );
        assert_eq!(
            err("x == 1"),
            "'==' at column 3 is not supported (coordinates are rarely exact): \
             compare with a tolerance, e.g. abs(x - 1) < 1e-9"
        );
        assert_eq!(err("x & y"), "'&' at column 3 is not an operator: write &&");
        assert_eq!(
            err("x ** 2"),
            "'**' at column 3 is not an operator: write ^ for powers"
        );
        assert_eq!(err("1e999"), "number '1e999' at column 1 is out of range");
        // Columns count characters, not bytes.
        assert_eq!(err("π π"), "missing operator before 'π' at column 3");
    }

    proptest::proptest! {
        /// Any text either parses or gives a one-line message; never a panic.
        #[test]
        fn never_panics(src in "[-+*/^<>=!&|(),. 0-9a-zπ\\n\\t]{0,40}") {
            match parse(&src) {
                Ok(e) => {
                    let _ = e.eval(0.5, -1.5, 2.0);
                }
                Err(message) => proptest::prop_assert!(!message.contains('\n')),
            }
        }

        /// Folding constants gives the same value as evaluating at run time.
        #[test]
        fn folding_matches_evaluation(a in -10.0f64..10.0, b in 0.1f64..10.0) {
            let folded = parse(&format!("({a:?}) * sqrt({b:?}) - ({a:?})^2 / {b:?}")).unwrap();
            let variable = parse("x * sqrt(y) - x^2 / y").unwrap();
            proptest::prop_assert!(folded.is_constant());
            proptest::prop_assert_eq!(folded.eval(0.0, 0.0, 0.0), variable.eval(a, b, 0.0));
        }
    }

    #[test]
    fn nesting_is_bounded_without_overflow() {
        let deep = format!("{}x{}", "(".repeat(100_000), ")".repeat(100_000));
        assert_eq!(err(&deep), too_nested());
        let calls = format!("{}x{}", "sin(".repeat(100_000), ")".repeat(100_000));
        assert_eq!(err(&calls), too_nested());
        let long = vec!["x"; 100_000].join(" + ");
        assert_eq!(err(&long), too_deep());
        let minus = format!("{}x", "-".repeat(100_000));
        assert_eq!(err(&minus), too_nested());
        let powers = vec!["x"; 100_000].join("^");
        assert_eq!(err(&powers), too_nested());
        let fine = format!("{}x{}", "(".repeat(60), ")".repeat(60));
        assert_eq!(ev(&fine, 2.0, 0.0, 0.0), 2.0);
        let sum = vec!["x"; 200].join(" + ");
        assert_eq!(ev(&sum, 1.0, 0.0, 0.0), 200.0);
    }

    #[test]
    fn size_is_bounded_at_parse_time() {
        // 10,000 arguments of max: 10,001 nodes.
        let wide = format!("max({})", vec!["x"; 10_000].join(", "));
        assert_eq!(
            err(&wide),
            "expression too large (10001 nodes after constant folding, limit 10000)"
        );
        let ok = format!("max({})", vec!["x"; 9_999].join(", "));
        assert_eq!(parse(&ok).unwrap().node_count(), 10_000);
        // Constants fold away and do not count.
        let constants = format!("max({})", vec!["1"; 50_000].join(", "));
        assert_eq!(parse(&constants).unwrap().node_count(), 1);
        let long = "1".repeat(1_000_001);
        assert!(err(&long).ends_with("is out of range"));
        assert!(err(&long).len() < 300, "{}", err(&long).len());
        let ident = "q".repeat(1 << 20);
        assert_eq!(
            err(&ident),
            format!(
                "unknown variable '{}… (1048576 characters)'",
                "q".repeat(200)
            )
        );
    }

    #[test]
    fn gradients_match_hand_derivatives_and_differences() {
        // Hand derivatives: ∇(x²y) = (2xy, x²); ∇ max(x − 0.3, 0)^4 = (4(x − 0.3)³, 0) right of
        // the kink and 0 left of it; ∇ sin(2x + y) = cos(2x + y)(2, 1).
        let e = Expr::parse("x^2*y").unwrap();
        let (v, g) = e.eval_gradient(1.5, -2.0);
        assert_eq!((v, g), (-4.5, [-6.0, 2.25]));
        let e = Expr::parse("max((x - 0.3), 0)^4").unwrap();
        let (_, g) = e.eval_gradient(0.5, 7.0);
        assert!(
            (g[0] - 4.0 * 0.2f64.powi(3)).abs() < 1e-15 && g[1] == 0.0,
            "{g:?}"
        );
        assert_eq!(e.eval_gradient(0.1, 7.0).1, [0.0, 0.0]);
        let e = Expr::parse("sin(2*x + y)").unwrap();
        let (_, g) = e.eval_gradient(0.3, 0.4);
        let c = (1.0f64).cos();
        assert!((g[0] - 2.0 * c).abs() < 1e-15 && (g[1] - c).abs() < 1e-15);
        // Every function against a central difference at a smooth point.
        for src in [
            "abs(x - 2*y) + acos(x/3) * asin(y/3) + atan(x*y)",
            "atan2(y, x) + hypot(x, y) + cosh(x) - sinh(y) + exp(-x*y)",
            "ln(x) + log10(x*y) + sqrt(x + y) + tan(y) * tanh(x)",
            "x^y + 2^x + y^3 / (1 + x) - min(x, y, 0.1) * max(x, y)",
            "-(x < y) + floor(x) + ceil(y) + sign(x) + cos(x^2)",
        ] {
            let e = Expr::parse(src).unwrap();
            let (x, y, hh) = (0.7, 0.45, 1e-6);
            let (v, g) = e.eval_gradient(x, y);
            assert_eq!(v, e.eval(x, y, 0.0), "{src}");
            let dx = (e.eval(x + hh, y, 0.0) - e.eval(x - hh, y, 0.0)) / (2.0 * hh);
            let dy = (e.eval(x, y + hh, 0.0) - e.eval(x, y - hh, 0.0)) / (2.0 * hh);
            assert!(
                (g[0] - dx).abs() < 1e-7 * (1.0 + dx.abs()),
                "{src}: {g:?} {dx}"
            );
            assert!(
                (g[1] - dy).abs() < 1e-7 * (1.0 + dy.abs()),
                "{src}: {g:?} {dy}"
            );
        }
    }

    #[test]
    fn checked_evaluation_names_the_expression_and_the_point() {
        let e = parse("1/x").unwrap();
        assert_eq!(e.eval_finite(2.0, 0.0, 0.0), Ok(0.5));
        assert_eq!(
            e.eval_finite(0.0, 0.5, 0.0).unwrap_err(),
            "expression \"1/x\" is infinite at (x, y) = (0.0, 0.5)"
        );
        let e = parse("sqrt(x - 0.5)").unwrap();
        assert_eq!(
            e.eval_finite(0.25, 1.0, 0.0).unwrap_err(),
            "expression \"sqrt(x - 0.5)\" is not a number (NaN) at (x, y) = (0.25, 1.0)"
        );
        assert!(
            parse("exp(1000*x)")
                .unwrap()
                .eval_finite(1.0, 0.0, 0.0)
                .is_err()
        );
        assert!(parse("0/0").unwrap().eval_finite(0.0, 0.0, 0.0).is_err());
        assert_eq!(parse("0/0").unwrap().node_count(), 1);
    }
}
