//! The parser: tokens to a syntax tree, one statement per line. A statement it cannot read
//! is reported and skipped to the end of its line, and blocks that do not close are closed
//! where the mismatch is found, so one pass reports every error it can.

use std::collections::HashSet;

use wrc_robot::Posture;

use crate::ast::{
    Arg, AxisRef, BinOp, CaseTest, Catch, ExitKind, Expr, ExprKind, LoopCond, MotionOpts, Name,
    Param, RoutineKind, Stmt, StmtKind, TypeDecl, UnOp,
};
use crate::diagnostic::{Diagnostic, Span};
use crate::lexer::{Tok, Token};
use crate::statements::{self, ArgSpec, Blend, StatementDef};

/// Deepest expression tree accepted (operators and parentheses nested).
pub(crate) const MAX_EXPR_DEPTH: u32 = 100;
/// Deepest block nesting accepted (IF, WHILE, FOR, … inside each other).
pub(crate) const MAX_BLOCK_DEPTH: usize = 64;
/// Most parameters of a SUB or FUNCTION.
pub(crate) const MAX_PARAMS: usize = 32;

/// Parse a token list (from [`crate::lexer::lex`]) into top-level statements.
pub(crate) fn parse(source: &str, tokens: &[Token], diags: &mut Vec<Diagnostic>) -> Vec<Stmt> {
    let file = tokens.first().map_or(0, |t| t.span.file);
    let mut p = Parser {
        src: source,
        toks: tokens,
        pos: 0,
        error_lines: diags
            .iter()
            .filter(|d| d.is_error() && d.file_index == file)
            .map(|d| d.line)
            .collect(),
        diags,
        nest: 0,
        inline_if: false,
    };
    let mut open = Vec::new();
    let mut stmts = Vec::new();
    loop {
        let (mut block, end) = p.block(&mut open);
        stmts.append(&mut block);
        match end {
            // At the top level nothing is open, so `block` reports stray closers itself and
            // only stops at the end of the file.
            End::Eof => break,
            End::Word { .. } | End::Outer => p.skip_line(),
        }
    }
    stmts
}

/// A block that is open while its body is parsed.
struct Open {
    /// `IF`, `WHILE`, `FOR`, `DO`, `SELECT`, `TRY`, `SUB` or `FUNCTION`.
    word: &'static str,
    span: Span,
    /// Words that end (or continue) this block.
    closers: &'static [&'static str],
}

/// Why a block's statement list ended.
enum End {
    /// A closer of the innermost block, not consumed: its word, span and token count.
    Word {
        key: &'static str,
        span: Span,
        tokens: usize,
    },
    /// A closer of an outer block (already reported): the inner block ends here.
    Outer,
    /// The end of the file.
    Eof,
}

const CLOSERS: &[&str] = &[
    "ENDIF",
    "ELSEIF",
    "ELSE",
    "ENDWHILE",
    "NEXT",
    "ENDSUB",
    "ENDFUNCTION",
    "LOOP",
    "CASE",
    "ENDSELECT",
    "CATCH",
    "ENDTRY",
];

fn opener_of(closer: &str) -> &'static str {
    match closer {
        "ENDIF" | "ELSEIF" | "ELSE" => "IF",
        "ENDWHILE" => "WHILE",
        "NEXT" => "FOR",
        "ENDFUNCTION" => "FUNCTION",
        "LOOP" => "DO",
        "CASE" | "ENDSELECT" => "SELECT CASE",
        "CATCH" | "ENDTRY" => "TRY",
        _ => "SUB",
    }
}

fn closer_of(opener: &str) -> &'static str {
    match opener {
        "IF" => "ENDIF",
        "WHILE" => "ENDWHILE",
        "FOR" => "NEXT",
        "FUNCTION" => "ENDFUNCTION",
        "DO" => "LOOP",
        "SELECT" => "ENDSELECT",
        "TRY" => "ENDTRY",
        _ => "ENDSUB",
    }
}

type PResult<T> = Result<T, ()>;

struct Parser<'a, 'd> {
    src: &'a str,
    toks: &'a [Token],
    pos: usize,
    diags: &'d mut Vec<Diagnostic>,
    /// Parentheses, calls and prefix operators open right now (bounds the recursion).
    nest: u32,
    /// Lines that already have an error.
    error_lines: HashSet<u32>,
    /// Inside the statement after a single-line `IF … THEN`: an `ELSE` ends it like the end
    /// of the line.
    inline_if: bool,
}

impl Parser<'_, '_> {
    fn peek(&self) -> &Token {
        // The lexer always ends with Eof, and `bump` never passes it.
        &self.toks[self.pos.min(self.toks.len() - 1)]
    }

    fn peek_at(&self, ahead: usize) -> &Token {
        &self.toks[(self.pos + ahead).min(self.toks.len() - 1)]
    }

    fn bump(&mut self) -> Token {
        let t = self.peek().clone();
        if t.tok != Tok::Eof {
            self.pos += 1;
        }
        t
    }

    fn text(&self, t: &Token) -> &str {
        self.src.get(t.start..t.end).unwrap_or("")
    }

    /// The upper-case text of an identifier token, or "" for any other token.
    fn key(&self, t: &Token) -> String {
        if t.tok == Tok::Ident {
            self.text(t).to_ascii_uppercase()
        } else {
            String::new()
        }
    }

    fn is_word(&self, t: &Token, word: &str) -> bool {
        t.tok == Tok::Ident && self.text(t).eq_ignore_ascii_case(word)
    }

    fn at_line_end(&self) -> bool {
        let t = self.peek();
        matches!(t.tok, Tok::Newline | Tok::Eof) || (self.inline_if && self.is_word(t, "ELSE"))
    }

    /// The line really ends here (a newline or the end of the file, not an inline `ELSE`).
    fn at_newline(&self) -> bool {
        matches!(self.peek().tok, Tok::Newline | Tok::Eof)
    }

    /// A syntax error in a statement: only the first error of a line is reported (the rest
    /// of a broken line rarely says anything new).
    fn error(&mut self, span: Span, message: impl Into<String>) {
        if self.error_lines.insert(span.line) {
            self.diags.push(Diagnostic::error(span, message));
        }
    }

    /// An error in the block structure: always reported.
    fn block_error(&mut self, span: Span, message: impl Into<String>) {
        self.error_lines.insert(span.line);
        self.diags.push(Diagnostic::error(span, message));
    }

    /// How a token reads in a message.
    fn describe(&self, t: &Token) -> String {
        match &t.tok {
            Tok::Newline => "the end of the line".into(),
            Tok::Eof => "the end of the file".into(),
            Tok::Str(_) => "a string".into(),
            Tok::Number(_) => format!("number {}", self.text(t)),
            Tok::Ident => format!("'{}'", self.text(t)),
            _ => format!("'{}'", self.text(t)),
        }
    }

    /// Skip to the start of the next line.
    fn skip_line(&mut self) {
        while !self.at_line_end() {
            self.bump();
        }
        if self.at_newline() {
            self.bump();
        }
    }

    /// Expect the end of the statement's line and consume it; otherwise report and skip.
    fn end_line(&mut self, what: &str) {
        if self.at_line_end() {
            if self.at_newline() {
                self.bump();
            }
            return;
        }
        let t = self.peek().clone();
        let msg = format!(
            "expected the end of the line after {what}, found {}",
            self.describe(&t)
        );
        self.error(t.span, msg);
        self.skip_line();
    }

    fn name(&self, t: &Token) -> Name {
        let text = self.text(t).to_string();
        Name {
            key: text.to_ascii_uppercase(),
            text,
            span: t.span,
        }
    }

    /// A closer word at the start of the line: its key and how many tokens it takes
    /// (`END IF`, `END TRY`, … are read as `ENDIF`, `ENDTRY`).
    fn closer_here(&mut self) -> Option<(&'static str, Span, usize)> {
        let t = self.peek().clone();
        if t.tok != Tok::Ident {
            return None;
        }
        let key = self.key(&t);
        if let Some(&c) = CLOSERS.iter().find(|&&c| c == key) {
            return Some((c, t.span, 1));
        }
        if key == "END" {
            let next = self.peek_at(1).clone();
            let joined = match self.key(&next).as_str() {
                "IF" => "ENDIF",
                "WHILE" => "ENDWHILE",
                "SUB" => "ENDSUB",
                "FUNCTION" => "ENDFUNCTION",
                "SELECT" => "ENDSELECT",
                "TRY" => "ENDTRY",
                _ => return None,
            };
            return Some((joined, t.span.to(next.span), 2));
        }
        None
    }

    /// Statements until a closer or the end of the file.
    fn block(&mut self, open: &mut Vec<Open>) -> (Vec<Stmt>, End) {
        let mut stmts = Vec::new();
        loop {
            while self.peek().tok == Tok::Newline {
                self.bump();
            }
            if self.peek().tok == Tok::Eof {
                return (stmts, End::Eof);
            }
            if let Some((key, span, tokens)) = self.closer_here() {
                if let Some(inner) = open.last() {
                    if inner.closers.contains(&key) {
                        return (stmts, End::Word { key, span, tokens });
                    }
                    if open.iter().any(|o| o.closers.contains(&key)) {
                        let msg = format!(
                            "expected {} to close {} at {}, found {key}",
                            closer_of(inner.word),
                            inner.word,
                            inner.span.at()
                        );
                        self.block_error(span, msg);
                        return (stmts, End::Outer);
                    }
                }
                let msg = format!("{key} without {}", opener_of(key));
                self.block_error(span, msg);
                self.skip_line();
                continue;
            }
            if let Ok(stmt) = self.statement(open) {
                stmts.push(stmt);
            }
        }
    }

    /// One statement, including a whole block statement.
    fn statement(&mut self, open: &mut Vec<Open>) -> PResult<Stmt> {
        let t = self.peek().clone();
        if t.tok != Tok::Ident {
            let msg = format!("expected a statement, found {}", self.describe(&t));
            self.error(t.span, msg);
            self.skip_line();
            return Err(());
        }
        let key = self.key(&t);
        match key.as_str() {
            "IF" | "WHILE" | "FOR" | "SUB" | "FUNCTION" | "DO" | "SELECT" | "TRY" => {
                if open.len() >= MAX_BLOCK_DEPTH {
                    self.error(
                        t.span,
                        format!("blocks nested deeper than {MAX_BLOCK_DEPTH}; move the inner part into a SUB"),
                    );
                    self.skip_line();
                    return Err(());
                }
                match key.as_str() {
                    "IF" => self.if_block(open),
                    "WHILE" => self.while_block(open),
                    "FOR" => self.for_block(open),
                    "DO" => self.do_block(open),
                    "SELECT" => self.select_block(open),
                    "TRY" => self.try_block(open),
                    "FUNCTION" => self.routine_block(open, RoutineKind::Function),
                    _ => self.routine_block(open, RoutineKind::Sub),
                }
            }
            "CALL" => self.call(),
            "DIM" => self.dim(),
            "LOCAL" => self.local(),
            "RETURN" => self.return_stmt(),
            "EXIT" => self.exit(),
            "RETRY" => {
                self.bump();
                self.end_line("RETRY");
                Ok(Stmt {
                    span: t.span,
                    kind: StmtKind::Retry,
                })
            }
            "INCLUDE" => self.include(open),
            _ => {
                let next = self.key(&self.peek_at(1).clone());
                if let Some(def) = statements::find(&key, &next) {
                    return self.command(def);
                }
                self.assignment()
            }
        }
    }

    /// `name = expr` or `name[i] = expr`.
    fn assignment(&mut self) -> PResult<Stmt> {
        let t = self.bump();
        let target = self.name(&t);
        let mut index = Vec::new();
        if self.peek().tok == Tok::LBracket {
            index = self.indices(&target)?;
        }
        let next = self.peek().clone();
        if next.tok != Tok::Eq {
            let msg = if next.tok == Tok::Dot {
                format!(
                    "a field of {} cannot be assigned; assign a whole new value (e.g. {} = POSE(x, y, z, yaw))",
                    target.text, target.text
                )
            } else if statements::is_reserved(&target.key) {
                format!("{} cannot start a statement", target.text)
            } else if next.tok == Tok::LParen {
                format!(
                    "{} is not a statement; to run a SUB write CALL {}(…)",
                    target.text, target.text
                )
            } else {
                format!(
                    "{} is not a statement; statements are {} and IF, WHILE, FOR, DO, SELECT CASE, TRY, SUB, FUNCTION, CALL, DIM, LOCAL; to assign a variable write {} = value",
                    target.text,
                    statement_list(),
                    target.text
                )
            };
            let span = if next.tok == Tok::Dot {
                target.span.to(self.peek_at(1).span)
            } else {
                target.span
            };
            self.error(span, msg);
            self.skip_line();
            return Err(());
        }
        self.bump();
        if statements::is_reserved(&target.key) {
            let msg = format!("{} is a keyword and cannot name a variable", target.text);
            self.error(target.span, msg);
            self.skip_line();
            return Err(());
        }
        let value = match self.expr() {
            Ok(e) => {
                self.end_line("the value");
                e
            }
            Err(()) => {
                // Keep the assignment so that later uses of the name are not reported too.
                self.skip_line();
                Expr {
                    kind: ExprKind::Error,
                    span: target.span,
                    depth: 1,
                }
            }
        };
        Ok(Stmt {
            span: target.span,
            kind: StmtKind::Assign {
                target,
                index,
                value,
            },
        })
    }

    /// `[i]` or `[i, j]` after an array's name.
    fn indices(&mut self, name: &Name) -> PResult<Vec<Expr>> {
        let open = self.bump();
        let mut out = Vec::new();
        loop {
            out.push(self.nested(open.span, |p| p.expr())?);
            if self.peek().tok == Tok::Comma {
                self.bump();
                continue;
            }
            break;
        }
        self.expect(
            Tok::RBracket,
            &format!("',' or ']' to close {}[", name.text),
        )?;
        Ok(out)
    }

    /// A statement from the table: its arguments by the table's grammar.
    fn command(&mut self, def: &'static StatementDef) -> PResult<Stmt> {
        let kw = self.bump();
        let mut span = kw.span;
        if self.peek().tok == Tok::Eq {
            // `MAP = 1`: a name that became a statement keyword.
            let msg = format!(
                "{} is a statement keyword and cannot name a variable; choose another name",
                self.text(&kw)
            );
            self.error(kw.span, msg);
            self.skip_line();
            return Err(());
        }
        if let Some(second) = def.second {
            let t = self.bump();
            debug_assert!(self.is_word(&t, second));
            span = span.to(t.span);
        }
        let result = self.command_args(def);
        match result {
            Ok(args) => {
                if self.peek().tok == Tok::Comma {
                    let t = self.peek().clone();
                    let msg = format!("too many arguments; the syntax is {}", def.syntax);
                    self.error(t.span, msg);
                    self.skip_line();
                    return Err(());
                }
                self.end_line(def.keyword);
                Ok(Stmt {
                    span,
                    kind: StmtKind::Command { def, args },
                })
            }
            Err(()) => {
                self.skip_line();
                Err(())
            }
        }
    }

    fn command_args(&mut self, def: &'static StatementDef) -> PResult<Vec<Arg>> {
        let mut args = Vec::with_capacity(def.args.len());
        for (i, spec) in def.args.iter().enumerate() {
            let needs_comma = i > 0 && matches!(spec, ArgSpec::Value { .. } | ArgSpec::Axis);
            if needs_comma {
                self.expect_comma(def)?;
            } else if i == 0
                && self.at_line_end()
                && !matches!(
                    spec,
                    ArgSpec::Keyword { .. } | ArgSpec::Motion { .. } | ArgSpec::OptValue { .. }
                )
            {
                let t = self.peek().clone();
                let msg = format!(
                    "{} needs arguments; the syntax is {}",
                    def.keyword, def.syntax
                );
                self.error(t.span, msg);
                return Err(());
            }
            let arg = match spec {
                ArgSpec::Value { .. } => Arg::Value(self.expr()?),
                ArgSpec::OptValue { .. } => {
                    // The first argument has no comma before it; a later one has.
                    if i == 0 {
                        if self.at_line_end() {
                            Arg::OptValue(None)
                        } else {
                            Arg::OptValue(Some(self.expr()?))
                        }
                    } else if self.peek().tok == Tok::Comma {
                        self.bump();
                        Arg::OptValue(Some(self.expr()?))
                    } else {
                        Arg::OptValue(None)
                    }
                }
                ArgSpec::Posture => Arg::Posture(self.posture(def)?),
                ArgSpec::Blade => Arg::Blade(self.blade(def)?),
                ArgSpec::Axis => Arg::Axis(self.axis()?),
                ArgSpec::Items => {
                    let mut items = vec![self.expr()?];
                    while self.peek().tok == Tok::Comma {
                        self.bump();
                        items.push(self.expr()?);
                    }
                    Arg::Items(items)
                }
                ArgSpec::Target => {
                    let t = self.peek().clone();
                    if t.tok != Tok::Ident {
                        let msg = format!(
                            "expected the name of a point, found {}; the syntax is {}",
                            self.describe(&t),
                            def.syntax
                        );
                        self.error(t.span, msg);
                        return Err(());
                    }
                    self.bump();
                    Arg::Target(self.name(&t))
                }
                ArgSpec::Input => self.input_condition(def)?,
                ArgSpec::Keyword { word, .. } => {
                    if self.is_word(&self.peek().clone(), word) {
                        self.bump();
                        Arg::Keyword(Some(self.expr()?))
                    } else {
                        Arg::Keyword(None)
                    }
                }
                ArgSpec::Motion { blend } => Arg::Motion(self.motion_opts(def, *blend)?),
            };
            args.push(arg);
        }
        Ok(args)
    }

    /// `SPEED pct`, `ACCEL pct`, `BLEND [zone]` in any order, each at most once.
    fn motion_opts(&mut self, def: &StatementDef, blend: Blend) -> PResult<MotionOpts> {
        let mut opts = MotionOpts::default();
        while !self.at_line_end() && self.peek().tok != Tok::Comma {
            let t = self.peek().clone();
            let key = self.key(&t);
            let seen = match key.as_str() {
                "SPEED" => opts.speed.is_some(),
                "ACCEL" => opts.accel.is_some(),
                "BLEND" if blend != Blend::No => opts.blend.is_some(),
                _ => {
                    let options = match blend {
                        Blend::No => "SPEED pct or ACCEL pct",
                        Blend::Pass => "SPEED pct, ACCEL pct or BLEND",
                        Blend::Zone => "SPEED pct, ACCEL pct or BLEND mm",
                    };
                    let msg = format!(
                        "expected the end of the line or an option ({options}), found {}; the syntax is {}",
                        self.describe(&t),
                        def.syntax
                    );
                    self.error(t.span, msg);
                    return Err(());
                }
            };
            if seen {
                self.error(t.span, format!("{key} is given twice"));
                return Err(());
            }
            self.bump();
            match key.as_str() {
                "SPEED" => opts.speed = Some(self.expr()?),
                "ACCEL" => opts.accel = Some(self.expr()?),
                _ => {
                    let zone = if blend == Blend::Zone {
                        if self.at_line_end() {
                            let msg = format!(
                                "BLEND needs the corner zone [mm] on {}: BLEND 5 rounds the corner within 5 mm",
                                def.keyword
                            );
                            self.error(t.span, msg);
                            return Err(());
                        }
                        Some(self.expr()?)
                    } else {
                        let next = self.peek().clone();
                        if matches!(next.tok, Tok::Number(_) | Tok::LParen) {
                            let msg = format!(
                                "BLEND on {} takes no distance: a PTP motion passes its target moving",
                                def.keyword
                            );
                            self.error(next.span, msg);
                            return Err(());
                        }
                        None
                    };
                    opts.blend = Some((t.span, zone));
                }
            }
        }
        Ok(opts)
    }

    fn expect_comma(&mut self, def: &StatementDef) -> PResult<()> {
        let t = self.peek().clone();
        if t.tok == Tok::Comma {
            self.bump();
            return Ok(());
        }
        let msg = format!(
            "expected ',' and the next argument, found {}; the syntax is {}",
            self.describe(&t),
            def.syntax
        );
        self.error(t.span, msg);
        Err(())
    }

    /// `, A|B` or nothing: whether blade B is named.
    fn blade(&mut self, def: &StatementDef) -> PResult<bool> {
        let words = [("A", false), ("B", true)];
        Ok(self
            .optional_word(def, &words, "the blade must be A or B")?
            .unwrap_or(false))
    }

    /// `, L|R` or nothing.
    fn posture(&mut self, def: &StatementDef) -> PResult<Option<Posture>> {
        let words = [
            ("L", Posture::Left),
            ("LEFT", Posture::Left),
            ("R", Posture::Right),
            ("RIGHT", Posture::Right),
        ];
        self.optional_word(
            def,
            &words,
            "the posture must be L or R (elbow left or right)",
        )
    }

    /// An optional `, WORD` whose word is one of `words` (case-insensitive): its value, or
    /// `None` when there is no comma; any other word is an error that says `must`.
    fn optional_word<T: Copy>(
        &mut self,
        def: &StatementDef,
        words: &[(&str, T)],
        must: &str,
    ) -> PResult<Option<T>> {
        if self.peek().tok != Tok::Comma {
            return Ok(None);
        }
        self.bump();
        let t = self.peek().clone();
        let key = self.key(&t);
        if let Some(&(_, value)) = words.iter().find(|(w, _)| *w == key) {
            self.bump();
            return Ok(Some(value));
        }
        let msg = format!(
            "{must}, found {}; the syntax is {}",
            self.describe(&t),
            def.syntax
        );
        self.error(t.span, msg);
        Err(())
    }

    /// An axis name or number.
    fn axis(&mut self) -> PResult<AxisRef> {
        let t = self.peek().clone();
        match t.tok {
            Tok::Ident => {
                self.bump();
                Ok(AxisRef::Name(self.name(&t)))
            }
            Tok::Number(n) => {
                self.bump();
                Ok(AxisRef::Number(n, t.span))
            }
            _ => {
                let msg = format!(
                    "expected an axis name (like J1) or number (1, 2, …), found {}",
                    self.describe(&t)
                );
                self.error(t.span, msg);
                Err(())
            }
        }
    }

    /// `IN(n) = value`.
    fn input_condition(&mut self, def: &StatementDef) -> PResult<Arg> {
        let t = self.peek().clone();
        if !self.is_word(&t, "IN") {
            let msg = format!(
                "expected IN(n) = 0|1 or OPERATOR, found {}; the syntax is {} (or WAIT OPERATOR [text])",
                self.describe(&t),
                def.syntax
            );
            self.error(t.span, msg);
            return Err(());
        }
        self.bump();
        self.expect(Tok::LParen, "'(' after IN")?;
        let n = self.expr()?;
        self.expect(Tok::RParen, "')' to close IN(")?;
        self.expect(Tok::Eq, "'=' and the level to wait for (0 or 1)")?;
        let value = self.expr()?;
        Ok(Arg::Input { n, value })
    }

    fn expect(&mut self, tok: Tok, what: &str) -> PResult<Token> {
        let t = self.peek().clone();
        if t.tok == tok {
            self.bump();
            return Ok(t);
        }
        let msg = format!("expected {what}, found {}", self.describe(&t));
        self.error(t.span, msg);
        Err(())
    }

    /// A name that is not a keyword, for a declaration (`what`: "a SUB", "a parameter", …).
    fn decl_name(&mut self, what: &str) -> PResult<Name> {
        let t = self.peek().clone();
        if t.tok != Tok::Ident {
            let msg = format!("expected the name of {what}, found {}", self.describe(&t));
            self.error(t.span, msg);
            return Err(());
        }
        self.bump();
        let name = self.name(&t);
        if statements::is_reserved(&name.key) {
            let msg = format!("{} is a keyword and cannot name {what}", name.text);
            self.error(name.span, msg);
            return Err(());
        }
        Ok(name)
    }

    /// An optional `AS type`.
    fn as_type(&mut self) -> PResult<Option<TypeDecl>> {
        if !self.is_word(&self.peek().clone(), "AS") {
            return Ok(None);
        }
        self.bump();
        let t = self.peek().clone();
        match statements::type_named(&self.key(&t)) {
            Some(ty) => {
                self.bump();
                Ok(Some(TypeDecl { ty, span: t.span }))
            }
            None => {
                let msg = format!(
                    "expected a type after AS (NUMBER, BOOLEAN, STRING, POSE or JOINTS), found {}",
                    self.describe(&t)
                );
                self.error(t.span, msg);
                Err(())
            }
        }
    }

    /// `CALL name [(args)]` or `CALL PROGRAM "name"`.
    fn call(&mut self) -> PResult<Stmt> {
        let kw = self.bump();
        let t = self.peek().clone();
        if self.is_word(&t, "PROGRAM") {
            self.bump();
            let s = self.peek().clone();
            let Tok::Str(name) = &s.tok else {
                let msg = format!(
                    "expected the program's name in quotes after CALL PROGRAM, found {}",
                    self.describe(&s)
                );
                self.error(s.span, msg);
                self.skip_line();
                return Err(());
            };
            self.bump();
            self.end_line("CALL PROGRAM's name");
            return Ok(Stmt {
                span: kw.span,
                kind: StmtKind::CallProgram {
                    name: name.clone(),
                    span: s.span,
                },
            });
        }
        if t.tok != Tok::Ident {
            let msg = format!("expected a SUB name, found {}", self.describe(&t));
            self.error(t.span, msg);
            self.skip_line();
            return Err(());
        }
        self.bump();
        let name = self.name(&t);
        let mut args = Vec::new();
        if self.peek().tok == Tok::LParen {
            let open = self.bump();
            if self.peek().tok != Tok::RParen {
                loop {
                    match self.nested(open.span, |p| p.expr()) {
                        Ok(e) => args.push(e),
                        Err(()) => {
                            self.skip_line();
                            return Err(());
                        }
                    }
                    if self.peek().tok == Tok::Comma {
                        self.bump();
                        continue;
                    }
                    break;
                }
            }
            if self
                .expect(Tok::RParen, &format!("',' or ')' to close {}(", name.text))
                .is_err()
            {
                self.skip_line();
                return Err(());
            }
        } else if !self.at_line_end() {
            let t = self.peek().clone();
            let msg = format!(
                "a SUB's arguments go in parentheses: CALL {}(a, b), found {}",
                name.text,
                self.describe(&t)
            );
            self.error(t.span, msg);
            self.skip_line();
            return Err(());
        }
        self.end_line("CALL");
        Ok(Stmt {
            span: kw.span,
            kind: StmtKind::Call { name, args },
        })
    }

    /// `DIM name[dims] [AS type]` or `DIM name AS type`.
    fn dim(&mut self) -> PResult<Stmt> {
        let kw = self.bump();
        let r = (|| {
            let name = self.decl_name("an array or variable")?;
            let dims = if self.peek().tok == Tok::LBracket {
                self.indices(&name)?
            } else {
                Vec::new()
            };
            let ty = self.as_type()?;
            if dims.is_empty() && ty.is_none() {
                let t = self.peek().clone();
                let msg = format!(
                    "DIM needs a size or a type: DIM {0}[10] (an array) or DIM {0} AS POSE, found {1}",
                    name.text,
                    self.describe(&t)
                );
                self.error(t.span, msg);
                return Err(());
            }
            Ok((name, dims, ty))
        })();
        match r {
            Ok((name, dims, ty)) => {
                self.end_line("the DIM declaration");
                Ok(Stmt {
                    span: kw.span,
                    kind: StmtKind::Dim { name, dims, ty },
                })
            }
            Err(()) => {
                self.skip_line();
                Err(())
            }
        }
    }

    /// `LOCAL name [AS type] [= value]`.
    fn local(&mut self) -> PResult<Stmt> {
        let kw = self.bump();
        let r = (|| {
            let name = self.decl_name("a local variable")?;
            if self.peek().tok == Tok::LBracket {
                let t = self.peek().clone();
                self.error(
                    t.span,
                    format!(
                        "a local array is declared with DIM: DIM {}[n] AS type",
                        name.text
                    ),
                );
                return Err(());
            }
            let ty = self.as_type()?;
            let init = if self.peek().tok == Tok::Eq {
                self.bump();
                Some(self.expr()?)
            } else {
                None
            };
            if ty.is_none() && init.is_none() {
                let t = self.peek().clone();
                let msg = format!(
                    "LOCAL needs a type or a first value: LOCAL {0} AS NUMBER or LOCAL {0} = 0, found {1}",
                    name.text,
                    self.describe(&t)
                );
                self.error(t.span, msg);
                return Err(());
            }
            Ok((name, ty, init))
        })();
        match r {
            Ok((name, ty, init)) => {
                self.end_line("the LOCAL declaration");
                Ok(Stmt {
                    span: kw.span,
                    kind: StmtKind::Local { name, ty, init },
                })
            }
            Err(()) => {
                self.skip_line();
                Err(())
            }
        }
    }

    fn return_stmt(&mut self) -> PResult<Stmt> {
        let kw = self.bump();
        let value = if self.at_line_end() {
            None
        } else {
            match self.expr() {
                Ok(e) => Some(e),
                Err(()) => {
                    self.skip_line();
                    return Err(());
                }
            }
        };
        self.end_line("RETURN");
        Ok(Stmt {
            span: kw.span,
            kind: StmtKind::Return(value),
        })
    }

    fn exit(&mut self) -> PResult<Stmt> {
        let kw = self.bump();
        let t = self.peek().clone();
        let kind = match self.key(&t).as_str() {
            "FOR" => ExitKind::For,
            "WHILE" => ExitKind::While,
            "DO" => ExitKind::Do,
            "SUB" => ExitKind::Sub,
            "FUNCTION" => ExitKind::Function,
            _ => {
                let msg = format!(
                    "expected what to leave after EXIT (FOR, WHILE, DO, SUB or FUNCTION), found {}",
                    self.describe(&t)
                );
                self.error(t.span, msg);
                self.skip_line();
                return Err(());
            }
        };
        self.bump();
        self.end_line("EXIT");
        Ok(Stmt {
            span: kw.span.to(t.span),
            kind: StmtKind::Exit(kind),
        })
    }

    /// `INCLUDE "name"`, at the top level only.
    fn include(&mut self, open: &[Open]) -> PResult<Stmt> {
        let kw = self.bump();
        if let Some(outer) = open.last() {
            let msg = format!(
                "INCLUDE must be at the top level, not inside {} at {}",
                outer.word,
                outer.span.at()
            );
            self.block_error(kw.span, msg);
        }
        let t = self.peek().clone();
        let Tok::Str(name) = &t.tok else {
            let msg = format!(
                "expected the library's name in quotes after INCLUDE, found {}",
                self.describe(&t)
            );
            self.error(t.span, msg);
            self.skip_line();
            return Err(());
        };
        self.bump();
        self.end_line("INCLUDE's name");
        Ok(Stmt {
            span: t.span,
            kind: StmtKind::Include { name: name.clone() },
        })
    }

    /// `THEN` (optional) and the end of the line after a condition.
    fn then_line(&mut self, word: &str) {
        let t = self.peek().clone();
        if self.is_word(&t, "THEN") {
            self.bump();
            if !self.at_line_end() {
                let t = self.peek().clone();
                self.error(
                    t.span,
                    format!("the statements of {word} … THEN go on the lines below it, and ENDIF closes the block"),
                );
                self.skip_line();
                return;
            }
        }
        self.end_line("the condition");
    }

    fn open(&mut self, open: &mut Vec<Open>, word: &'static str, span: Span) {
        let closers: &'static [&'static str] = match word {
            "IF" => &["ENDIF", "ELSEIF", "ELSE"],
            "WHILE" => &["ENDWHILE"],
            "FOR" => &["NEXT"],
            "DO" => &["LOOP"],
            "SELECT" => &["CASE", "ENDSELECT"],
            "TRY" => &["CATCH", "ENDTRY"],
            "FUNCTION" => &["ENDFUNCTION"],
            _ => &["ENDSUB"],
        };
        open.push(Open {
            word,
            span,
            closers,
        });
    }

    fn unclosed_at_eof(&mut self, word: &str, span: Span) {
        let eof = self.peek().span;
        let msg = format!(
            "expected {} to close {word} at {}, found the end of the file",
            closer_of(word),
            span.at()
        );
        self.block_error(eof, msg);
    }

    /// A condition; on error the line is skipped and an error expression stands in.
    fn condition(&mut self, word: &str) -> Expr {
        let start = self.peek().span;
        if self.at_line_end() {
            let msg = match word {
                "WHILE" | "UNTIL" => format!("{word} needs a condition: {word} condition"),
                _ => format!("{word} needs a condition: {word} condition THEN"),
            };
            self.error(start, msg);
            self.skip_line();
            return error_expr(start);
        }
        match self.expr() {
            Ok(e) => {
                if word == "WHILE" || word == "UNTIL" {
                    self.end_line("the condition");
                } else {
                    self.then_line(word);
                }
                e
            }
            Err(()) => {
                self.skip_line();
                error_expr(start)
            }
        }
    }

    fn if_block(&mut self, open: &mut Vec<Open>) -> PResult<Stmt> {
        let kw = self.bump();
        // `IF cond THEN statement [ELSE statement]` on one line: no ENDIF.
        let cond = if self.at_line_end() {
            self.condition("IF")
        } else {
            let start = self.peek().span;
            match self.expr() {
                Ok(cond) => {
                    let then = self.peek().clone();
                    if self.is_word(&then, "THEN")
                        && !matches!(self.peek_at(1).tok, Tok::Newline | Tok::Eof)
                    {
                        self.bump();
                        return self.inline_if(kw.span, cond, open);
                    }
                    self.then_line("IF");
                    cond
                }
                Err(()) => {
                    self.skip_line();
                    error_expr(start)
                }
            }
        };
        self.open(open, "IF", kw.span);
        let mut arms = Vec::new();
        let mut else_block = Vec::new();
        let mut current = cond;
        let mut in_else = false;
        let mut else_span: Option<Span> = None;
        loop {
            let (body, end) = self.block(open);
            if in_else {
                else_block = body;
            } else {
                arms.push((current.clone(), body));
            }
            match end {
                End::Word { key, span, tokens } => {
                    for _ in 0..tokens {
                        self.bump();
                    }
                    match key {
                        "ELSEIF" => {
                            if let Some(e) = else_span {
                                self.block_error(
                                    span,
                                    format!(
                                        "ELSEIF after ELSE (at {}); ELSE must be the last branch",
                                        e.at()
                                    ),
                                );
                            }
                            current = self.condition("ELSEIF");
                        }
                        "ELSE" => {
                            if let Some(e) = else_span {
                                self.block_error(
                                    span,
                                    format!(
                                        "a second ELSE in this IF (the first is at {})",
                                        e.at()
                                    ),
                                );
                            }
                            else_span = Some(span);
                            in_else = true;
                            self.end_line("ELSE");
                            continue;
                        }
                        _ => {
                            self.end_line("ENDIF");
                            break;
                        }
                    }
                    if in_else {
                        // An ELSEIF after ELSE was reported; keep reading its block as
                        // part of the ELSE.
                        continue;
                    }
                }
                End::Outer => break,
                End::Eof => {
                    self.unclosed_at_eof("IF", kw.span);
                    break;
                }
            }
        }
        open.pop();
        Ok(Stmt {
            span: kw.span,
            kind: StmtKind::If { arms, else_block },
        })
    }

    /// The rest of a single-line `IF cond THEN statement [ELSE statement]`.
    fn inline_if(&mut self, span: Span, cond: Expr, open: &mut Vec<Open>) -> PResult<Stmt> {
        let then = self.inline_statement(open, "THEN", true);
        let mut else_block = Vec::new();
        let t = self.peek().clone();
        if then.is_ok() && self.is_word(&t, "ELSE") {
            self.bump();
            else_block.push(self.inline_statement(open, "ELSE", false)?);
        } else if self.is_word(&t, "ELSE") {
            // The THEN statement was refused: the rest of the line goes with it.
            self.skip_line();
        }
        Ok(Stmt {
            span,
            kind: StmtKind::If {
                arms: vec![(cond, vec![then?])],
                else_block,
            },
        })
    }

    /// One simple statement after `THEN` or `ELSE` on a single-line IF; `before_else`: an
    /// `ELSE` may follow it on the line.
    fn inline_statement(
        &mut self,
        open: &mut Vec<Open>,
        after: &str,
        before_else: bool,
    ) -> PResult<Stmt> {
        let t = self.peek().clone();
        let key = self.key(&t);
        let block = matches!(
            key.as_str(),
            "IF" | "WHILE" | "FOR" | "SUB" | "FUNCTION" | "DO" | "SELECT" | "TRY" | "INCLUDE"
        ) || CLOSERS.contains(&key.as_str())
            || key == "END"
                && matches!(
                    self.key(&self.peek_at(1).clone()).as_str(),
                    "IF" | "WHILE" | "SUB" | "FUNCTION" | "SELECT" | "TRY"
                );
        let refusal = if t.tok == Tok::Ident && block {
            Some(format!(
                "after {after} on the same line only a simple statement may follow, not {}; put a block on the lines below IF … THEN and close it with ENDIF",
                self.text(&t)
            ))
        } else if t.tok == Tok::Newline || t.tok == Tok::Eof || self.is_word(&t, "ELSE") {
            Some(format!(
                "expected a statement after {after}, found {}",
                self.describe(&t)
            ))
        } else {
            None
        };
        if let Some(msg) = refusal {
            self.error(t.span, msg);
            // The rest of the line, an ELSE part included, goes with it.
            self.inline_if = false;
            self.skip_line();
            return Err(());
        }
        self.inline_if = before_else;
        let r = self.statement(open);
        self.inline_if = false;
        r
    }

    fn while_block(&mut self, open: &mut Vec<Open>) -> PResult<Stmt> {
        let kw = self.bump();
        let cond = self.condition("WHILE");
        self.open(open, "WHILE", kw.span);
        let (body, end) = self.block(open);
        open.pop();
        self.close(end, "WHILE", kw.span);
        Ok(Stmt {
            span: kw.span,
            kind: StmtKind::While { cond, body },
        })
    }

    /// Consume a simple block's closer, or report the end of the file.
    fn close(&mut self, end: End, word: &str, span: Span) -> Option<Span> {
        match end {
            End::Word { tokens, span, key } => {
                for _ in 0..tokens {
                    self.bump();
                }
                if key != "NEXT" && key != "LOOP" {
                    self.end_line(key);
                }
                Some(span)
            }
            End::Outer => None,
            End::Eof => {
                self.unclosed_at_eof(word, span);
                None
            }
        }
    }

    fn for_block(&mut self, open: &mut Vec<Open>) -> PResult<Stmt> {
        let kw = self.bump();
        let header = self.for_header();
        if header.is_err() {
            self.skip_line();
        }
        self.open(open, "FOR", kw.span);
        let (body, end) = self.block(open);
        open.pop();
        let next_span = self.close(end, "FOR", kw.span);
        let mut next = next_span.unwrap_or(kw.span);
        if next_span.is_some() {
            // NEXT [name]
            let t = self.peek().clone();
            if t.tok == Tok::Ident {
                self.bump();
                let name = self.name(&t);
                if let Ok((var, ..)) = &header {
                    if name.key != var.key {
                        self.block_error(
                            name.span,
                            format!(
                                "NEXT {} does not match FOR {} at {}",
                                name.text,
                                var.text,
                                kw.span.at()
                            ),
                        );
                    }
                }
                next = next.to(name.span);
            }
            self.end_line("NEXT");
        }
        let (var, from, to, step) = header?;
        Ok(Stmt {
            span: kw.span,
            kind: StmtKind::For {
                var,
                from: Box::new(from),
                to: Box::new(to),
                step: step.map(Box::new),
                body,
                next,
            },
        })
    }

    #[allow(clippy::type_complexity)]
    fn for_header(&mut self) -> PResult<(Name, Expr, Expr, Option<Expr>)> {
        let t = self.peek().clone();
        if t.tok != Tok::Ident || statements::is_reserved(&self.key(&t)) {
            let msg = format!(
                "expected the loop variable, found {}; the syntax is FOR i = first TO last [STEP step]",
                self.describe(&t)
            );
            self.error(t.span, msg);
            return Err(());
        }
        self.bump();
        let var = self.name(&t);
        self.expect(Tok::Eq, "'=' after the loop variable")?;
        let from = self.expr()?;
        let t = self.peek().clone();
        if !self.is_word(&t, "TO") {
            let msg = format!(
                "expected TO and the last value, found {}",
                self.describe(&t)
            );
            self.error(t.span, msg);
            return Err(());
        }
        self.bump();
        let to = self.expr()?;
        let step = if self.is_word(&self.peek().clone(), "STEP") {
            self.bump();
            Some(self.expr()?)
        } else {
            None
        };
        self.end_line("the FOR header");
        Ok((var, from, to, step))
    }

    /// An optional `WHILE cond` or `UNTIL cond` after `DO` or `LOOP`.
    fn loop_cond(&mut self, after: &str) -> Option<LoopCond> {
        let t = self.peek().clone();
        let until = match self.key(&t).as_str() {
            "WHILE" => false,
            "UNTIL" => true,
            _ => {
                if !self.at_line_end() {
                    let msg = format!(
                        "expected WHILE condition, UNTIL condition or the end of the line after {after}, found {}",
                        self.describe(&t)
                    );
                    self.error(t.span, msg);
                    self.skip_line();
                } else {
                    self.bump();
                }
                return None;
            }
        };
        self.bump();
        let cond = self.condition(if until { "UNTIL" } else { "WHILE" });
        Some(LoopCond { until, cond })
    }

    /// `DO [WHILE|UNTIL cond]` … `LOOP [WHILE|UNTIL cond]`.
    fn do_block(&mut self, open: &mut Vec<Open>) -> PResult<Stmt> {
        let kw = self.bump();
        let pre = self.loop_cond("DO");
        self.open(open, "DO", kw.span);
        let (body, end) = self.block(open);
        open.pop();
        let loop_span = self.close(end, "DO", kw.span);
        let post = if loop_span.is_some() {
            self.loop_cond("LOOP")
        } else {
            None
        };
        if let (Some(_), Some(p)) = (&pre, &post) {
            let span = p.cond.span;
            self.block_error(
                span,
                "a DO loop has one condition: after DO or after LOOP, not both",
            );
        }
        Ok(Stmt {
            span: kw.span,
            kind: StmtKind::Do {
                pre,
                post,
                body,
                end: loop_span.unwrap_or(kw.span),
            },
        })
    }

    /// The value tests of a `CASE` line: `v`, `lo TO hi`, separated by commas.
    fn case_tests(&mut self) -> PResult<Vec<CaseTest>> {
        let mut tests = Vec::new();
        loop {
            let t = self.peek().clone();
            let compares = comparison(&self.peek_at(1).tok);
            if let Some(cmp) = compares.filter(|_| self.is_word(&t, "IS")) {
                self.bump(); // IS
                self.bump(); // the comparison
                let value = self.expr()?;
                tests.push(CaseTest::Cmp(cmp, value));
                if self.peek().tok == Tok::Comma {
                    self.bump();
                    continue;
                }
                return Ok(tests);
            }
            let first = self.expr()?;
            if self.is_word(&self.peek().clone(), "TO") {
                self.bump();
                let last = self.expr()?;
                tests.push(CaseTest::Range(first, last));
            } else {
                tests.push(CaseTest::Is(first));
            }
            if self.peek().tok == Tok::Comma {
                self.bump();
                continue;
            }
            return Ok(tests);
        }
    }

    /// `SELECT CASE subject` … `CASE v, lo TO hi` … `CASE ELSE` … `ENDSELECT`.
    fn select_block(&mut self, open: &mut Vec<Open>) -> PResult<Stmt> {
        let kw = self.bump();
        let t = self.peek().clone();
        if !self.is_word(&t, "CASE") {
            let msg = format!(
                "expected CASE after SELECT (SELECT CASE value), found {}",
                self.describe(&t)
            );
            self.error(t.span, msg);
            self.skip_line();
            return Err(());
        }
        self.bump();
        let subject = match self.expr() {
            Ok(e) => {
                self.end_line("the value SELECT CASE tests");
                e
            }
            Err(()) => {
                self.skip_line();
                error_expr(t.span)
            }
        };
        self.open(open, "SELECT", kw.span);
        let mut cases: Vec<(Vec<CaseTest>, Vec<Stmt>, Span)> = Vec::new();
        let mut else_block: Option<Vec<Stmt>> = None;
        // Before the first CASE: nothing but blank lines.
        let (before, mut end) = self.block(open);
        if let Some(s) = before.first() {
            self.block_error(
                s.span,
                "statements between SELECT CASE and its first CASE never run; start with CASE",
            );
        }
        loop {
            match end {
                End::Word { key, span, tokens } => {
                    for _ in 0..tokens {
                        self.bump();
                    }
                    if key == "ENDSELECT" {
                        self.end_line("ENDSELECT");
                        break;
                    }
                    // CASE …
                    let is_else = self.is_word(&self.peek().clone(), "ELSE");
                    let tests = if is_else {
                        self.bump();
                        if else_block.is_some() {
                            self.block_error(span, "a second CASE ELSE in this SELECT CASE");
                        }
                        self.end_line("CASE ELSE");
                        None
                    } else if else_block.is_some() {
                        self.block_error(span, "CASE after CASE ELSE; CASE ELSE must be the last");
                        self.skip_line();
                        None
                    } else {
                        match self.case_tests() {
                            Ok(tests) => {
                                self.end_line("the CASE values");
                                Some(tests)
                            }
                            Err(()) => {
                                self.skip_line();
                                Some(Vec::new())
                            }
                        }
                    };
                    let (body, next) = self.block(open);
                    match tests {
                        Some(tests) => cases.push((tests, body, span)),
                        None if is_else => else_block = Some(body),
                        None => {}
                    }
                    end = next;
                }
                End::Outer => break,
                End::Eof => {
                    self.unclosed_at_eof("SELECT", kw.span);
                    break;
                }
            }
        }
        open.pop();
        Ok(Stmt {
            span: kw.span,
            kind: StmtKind::Select {
                subject,
                cases,
                else_block,
            },
        })
    }

    /// `TRY` … `CATCH [code, …]` … `ENDTRY`.
    fn try_block(&mut self, open: &mut Vec<Open>) -> PResult<Stmt> {
        let kw = self.bump();
        self.end_line("TRY");
        self.open(open, "TRY", kw.span);
        let (body, mut end) = self.block(open);
        let mut catches: Vec<Catch> = Vec::new();
        let mut catch_all: Option<Span> = None;
        loop {
            match end {
                End::Word { key, span, tokens } => {
                    for _ in 0..tokens {
                        self.bump();
                    }
                    if key == "ENDTRY" {
                        self.end_line("ENDTRY");
                        break;
                    }
                    // CATCH [codes]
                    let mut codes = Vec::new();
                    if !self.at_line_end() {
                        loop {
                            match self.expr() {
                                Ok(e) => codes.push(e),
                                Err(()) => {
                                    self.skip_line();
                                    break;
                                }
                            }
                            if self.peek().tok == Tok::Comma {
                                self.bump();
                                continue;
                            }
                            self.end_line("the CATCH codes");
                            break;
                        }
                    } else {
                        self.bump();
                    }
                    if let Some(all) = catch_all {
                        self.block_error(
                            span,
                            format!(
                                "this CATCH never runs: the CATCH at {} (without codes) catches every error",
                                all.at()
                            ),
                        );
                    }
                    if codes.is_empty() {
                        catch_all.get_or_insert(span);
                    }
                    let (body, next) = self.block(open);
                    catches.push(Catch { codes, body, span });
                    end = next;
                }
                End::Outer => break,
                End::Eof => {
                    self.unclosed_at_eof("TRY", kw.span);
                    break;
                }
            }
        }
        open.pop();
        if catches.is_empty() {
            self.block_error(
                kw.span,
                "TRY needs at least one CATCH: TRY … CATCH [codes] … ENDTRY",
            );
        }
        Ok(Stmt {
            span: kw.span,
            kind: StmtKind::Try { body, catches },
        })
    }

    /// `SUB name [(params)]` … `ENDSUB` or `FUNCTION name(params) [AS type]` …
    /// `ENDFUNCTION`.
    fn routine_block(&mut self, open: &mut Vec<Open>, kind: RoutineKind) -> PResult<Stmt> {
        let kw = self.bump();
        let word = kind.word();
        if let Some(outer) = open.last() {
            let msg = format!(
                "{word} must be at the top level, not inside {} at {}",
                outer.word,
                outer.span.at()
            );
            self.block_error(kw.span, msg);
        }
        let header = (|| {
            let what = if kind == RoutineKind::Sub {
                "a SUB"
            } else {
                "a FUNCTION"
            };
            let name = self.decl_name(what)?;
            let mut params = Vec::new();
            if self.peek().tok == Tok::LParen {
                self.bump();
                if self.peek().tok != Tok::RParen {
                    loop {
                        let p = self.decl_name("a parameter")?;
                        let ty = self.as_type()?;
                        params.push(Param { name: p, ty });
                        if self.peek().tok == Tok::Comma {
                            self.bump();
                            continue;
                        }
                        break;
                    }
                }
                self.expect(Tok::RParen, "',' or ')' to close the parameters")?;
            } else if kind == RoutineKind::Function {
                let t = self.peek().clone();
                let msg = format!(
                    "a FUNCTION's parameters go in parentheses, also when there are none: FUNCTION {}()",
                    name.text
                );
                self.error(t.span, msg);
                return Err(());
            }
            if params.len() > MAX_PARAMS {
                self.error(
                    name.span,
                    format!("{word} {} has more than {MAX_PARAMS} parameters", name.text),
                );
                return Err(());
            }
            let ret = self.as_type()?;
            if ret.is_some() && kind == RoutineKind::Sub {
                self.error(
                    name.span,
                    format!(
                        "a SUB returns no value; write FUNCTION {} to return one",
                        name.text
                    ),
                );
                return Err(());
            }
            Ok((name, params, ret))
        })();
        match &header {
            Ok(_) => self.end_line(&format!("the {word} header")),
            Err(()) => self.skip_line(),
        }
        let opener = if kind == RoutineKind::Sub {
            "SUB"
        } else {
            "FUNCTION"
        };
        self.open(open, opener, kw.span);
        let (body, end) = self.block(open);
        open.pop();
        self.close(end, opener, kw.span);
        let (name, params, ret) = header?;
        Ok(Stmt {
            span: kw.span,
            kind: StmtKind::Routine {
                kind,
                name,
                params,
                ret,
                body,
            },
        })
    }

    // ----- expressions -----

    pub(crate) fn expr(&mut self) -> PResult<Expr> {
        self.or_expr()
    }

    /// Enter a nested expression (parenthesis, call, prefix operator): an error beyond
    /// [`MAX_EXPR_DEPTH`], so that deep input cannot overflow the stack.
    fn enter(&mut self, span: Span) -> PResult<()> {
        if self.nest >= MAX_EXPR_DEPTH {
            self.error(
                span,
                format!("expression nested deeper than {MAX_EXPR_DEPTH}; split it with variables"),
            );
            return Err(());
        }
        self.nest += 1;
        Ok(())
    }

    /// A nested part: `f` between [`Parser::enter`] and leaving.
    fn nested<T>(&mut self, span: Span, f: impl FnOnce(&mut Self) -> PResult<T>) -> PResult<T> {
        self.enter(span)?;
        let r = f(self);
        self.nest -= 1;
        r
    }

    fn node(&mut self, kind: ExprKind, span: Span, depth: u32) -> PResult<Expr> {
        if depth > MAX_EXPR_DEPTH {
            self.error(
                span,
                format!("expression nested deeper than {MAX_EXPR_DEPTH}; split it with variables"),
            );
            return Err(());
        }
        Ok(Expr { kind, span, depth })
    }

    fn binary(&mut self, op: BinOp, op_span: Span, l: Expr, r: Expr) -> PResult<Expr> {
        let span = l.span.to(r.span);
        let depth = l.depth.max(r.depth) + 1;
        self.node(
            ExprKind::Binary(op, op_span, Box::new(l), Box::new(r)),
            span,
            depth,
        )
    }

    fn or_expr(&mut self) -> PResult<Expr> {
        let mut l = self.and_expr()?;
        while self.is_word(&self.peek().clone(), "OR") {
            let op = self.bump();
            let r = self.and_expr()?;
            l = self.binary(BinOp::Or, op.span, l, r)?;
        }
        Ok(l)
    }

    fn and_expr(&mut self) -> PResult<Expr> {
        let mut l = self.not_expr()?;
        while self.is_word(&self.peek().clone(), "AND") {
            let op = self.bump();
            let r = self.not_expr()?;
            l = self.binary(BinOp::And, op.span, l, r)?;
        }
        Ok(l)
    }

    fn not_expr(&mut self) -> PResult<Expr> {
        let t = self.peek().clone();
        if self.is_word(&t, "NOT") {
            self.bump();
            let e = self.nested(t.span, |p| p.not_expr())?;
            let span = t.span.to(e.span);
            let depth = e.depth + 1;
            return self.node(ExprKind::Unary(UnOp::Not, Box::new(e)), span, depth);
        }
        self.cmp_expr()
    }

    fn cmp_expr(&mut self) -> PResult<Expr> {
        let mut l = self.add_expr()?;
        loop {
            let Some(op) = comparison(&self.peek().tok) else {
                return Ok(l);
            };
            let t = self.bump();
            let r = self.add_expr()?;
            l = self.binary(op, t.span, l, r)?;
        }
    }

    fn add_expr(&mut self) -> PResult<Expr> {
        let mut l = self.mul_expr()?;
        loop {
            let op = match self.peek().tok {
                Tok::Plus => BinOp::Add,
                Tok::Minus => BinOp::Sub,
                _ => return Ok(l),
            };
            let t = self.bump();
            let r = self.mul_expr()?;
            l = self.binary(op, t.span, l, r)?;
        }
    }

    fn mul_expr(&mut self) -> PResult<Expr> {
        let mut l = self.unary()?;
        loop {
            let op = match self.peek().tok {
                Tok::Star => BinOp::Mul,
                Tok::Slash => BinOp::Div,
                Tok::Ident if self.is_word(&self.peek().clone(), "MOD") => BinOp::Mod,
                _ => return Ok(l),
            };
            let t = self.bump();
            let r = self.unary()?;
            l = self.binary(op, t.span, l, r)?;
        }
    }

    fn unary(&mut self) -> PResult<Expr> {
        let t = self.peek().clone();
        match t.tok {
            Tok::Minus | Tok::Plus => {
                self.bump();
                let e = self.nested(t.span, |p| p.unary())?;
                if t.tok == Tok::Plus {
                    return Ok(e);
                }
                let span = t.span.to(e.span);
                let depth = e.depth + 1;
                self.node(ExprKind::Unary(UnOp::Neg, Box::new(e)), span, depth)
            }
            _ => self.postfix(),
        }
    }

    fn postfix(&mut self) -> PResult<Expr> {
        let mut e = self.primary()?;
        while self.peek().tok == Tok::Dot {
            self.bump();
            let t = self.peek().clone();
            if t.tok != Tok::Ident {
                let msg = format!(
                    "expected a field name after '.' (X, Y, Z, YAW or J1, J2, …), found {}",
                    self.describe(&t)
                );
                self.error(t.span, msg);
                return Err(());
            }
            self.bump();
            let field = self.name(&t);
            let span = e.span.to(field.span);
            let depth = e.depth + 1;
            e = self.node(ExprKind::Field(Box::new(e), field), span, depth)?;
        }
        Ok(e)
    }

    fn primary(&mut self) -> PResult<Expr> {
        let t = self.peek().clone();
        match &t.tok {
            Tok::Number(v) => {
                self.bump();
                self.node(ExprKind::Num(*v), t.span, 1)
            }
            Tok::Str(s) => {
                self.bump();
                self.node(ExprKind::Str(s.clone()), t.span, 1)
            }
            Tok::LParen => {
                self.bump();
                let inner = self.nested(t.span, |p| p.expr())?;
                let close = self.expect(Tok::RParen, "')' to close '('")?;
                let depth = inner.depth + 1;
                // Keep the inner expression; widen its span to the parentheses.
                let span = t.span.to(close.span);
                self.node(inner.kind, span, depth)
            }
            Tok::Ident => {
                self.bump();
                let name = self.name(&t);
                match name.key.as_str() {
                    "TRUE" => return self.node(ExprKind::Bool(true), t.span, 1),
                    "FALSE" => return self.node(ExprKind::Bool(false), t.span, 1),
                    _ => {}
                }
                if self.peek().tok == Tok::LParen {
                    self.bump();
                    let mut args = Vec::new();
                    let mut depth = 1;
                    if self.peek().tok != Tok::RParen {
                        loop {
                            let a = self.nested(t.span, |p| p.expr())?;
                            depth = depth.max(a.depth + 1);
                            args.push(a);
                            if self.peek().tok == Tok::Comma {
                                self.bump();
                                continue;
                            }
                            break;
                        }
                    }
                    let close =
                        self.expect(Tok::RParen, &format!("',' or ')' to close {}(", name.text))?;
                    let span = name.span.to(close.span);
                    return self.node(ExprKind::Call(name, args), span, depth);
                }
                if self.peek().tok == Tok::LBracket {
                    let close_at = self.pos;
                    let index = self.indices(&name)?;
                    let end = self.toks[self.pos.saturating_sub(1).max(close_at)].span;
                    let depth = index.iter().map(|e| e.depth).max().unwrap_or(0) + 1;
                    let span = name.span.to(end);
                    return self.node(ExprKind::Index(name, index), span, depth);
                }
                if crate::builtins::find(&name.key).is_some_and(|b| b.bare) {
                    return self.node(ExprKind::Call(name, Vec::new()), t.span, 1);
                }
                if statements::is_reserved(&name.key) {
                    let msg = match name.key.as_str() {
                        "JOINTS" | "POSE" => {
                            format!("{} needs its arguments in parentheses", name.text)
                        }
                        _ => format!("expected a value, found keyword {}", name.text),
                    };
                    self.error(name.span, msg);
                    return Err(());
                }
                self.node(ExprKind::Var(name), t.span, 1)
            }
            _ => {
                let msg = format!("expected a value, found {}", self.describe(&t));
                self.error(t.span, msg);
                Err(())
            }
        }
    }
}

/// `HOME, MOVEJ, …` for messages.
fn statement_list() -> String {
    let mut words: Vec<&str> = Vec::new();
    for d in statements::STATEMENTS {
        if !words.contains(&d.keyword) {
            words.push(d.keyword);
        }
    }
    words.join(", ")
}

/// An expression standing in for one that could not be read (already reported).
fn error_expr(span: Span) -> Expr {
    Expr {
        kind: ExprKind::Error,
        span,
        depth: 1,
    }
}

/// The comparison operator `tok` is, if it is one (`=`, `<>`, `<`, `<=`, `>`, `>=`).
fn comparison(tok: &Tok) -> Option<BinOp> {
    Some(match tok {
        Tok::Eq => BinOp::Eq,
        Tok::Ne => BinOp::Ne,
        Tok::Lt => BinOp::Lt,
        Tok::Le => BinOp::Le,
        Tok::Gt => BinOp::Gt,
        Tok::Ge => BinOp::Ge,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lexer::lex;

    fn parse_src(src: &str) -> (Vec<Stmt>, Vec<Diagnostic>) {
        let mut d = Vec::new();
        let toks = lex(src, 0, &mut d);
        let s = parse(src, &toks, &mut d);
        (s, d)
    }

    #[test]
    fn precedence_binds_mul_before_add_before_compare_before_and() {
        let (s, d) = parse_src("B = 1 + 2 * 3 = 7 AND NOT FALSE\n");
        assert!(d.is_empty(), "{d:?}");
        let StmtKind::Assign { value, .. } = &s[0].kind else {
            panic!()
        };
        let ExprKind::Binary(BinOp::And, _, l, _) = &value.kind else {
            panic!("{value:?}")
        };
        let ExprKind::Binary(BinOp::Eq, _, l, _) = &l.kind else {
            panic!()
        };
        assert!(matches!(l.kind, ExprKind::Binary(BinOp::Add, ..)));
    }

    #[test]
    fn a_mismatched_closer_names_the_open_block() {
        let (_, d) = parse_src("WHILE TRUE\n  IF X THEN\n  ENDWHILE\n");
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!(
            d[0].message,
            "expected ENDIF to close IF at 2:3, found ENDWHILE"
        );
        assert_eq!((d[0].line, d[0].col), (3, 3));
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_crash() {
        let src = format!("X = {}1{}\n", "(".repeat(5000), ")".repeat(5000));
        let (_, d) = parse_src(&src);
        assert!(!d.is_empty());
        let src = format!("X = 1{}\n", " + 1".repeat(5000));
        let (_, d) = parse_src(&src);
        assert!(!d.is_empty());
        let src = "IF TRUE THEN\n".repeat(5000);
        let (_, d) = parse_src(&src);
        assert!(!d.is_empty());
    }
}
