#include "tools/common/cli_docs.hpp"

#include <algorithm>
#include <map>
#include <sstream>

#include <fmt/format.h>

namespace hdrd::cli {
namespace {

std::map<const CLI::Option*, ValueHint>& hints() {
  static std::map<const CLI::Option*, ValueHint> h;
  return h;
}

// CLI11 hides options and subcommands by giving them the group "".
std::vector<const CLI::Option*> visible_options(const CLI::App& app) {
  return app.get_options([](const CLI::Option* o) { return !o->get_group().empty(); });
}
std::vector<const CLI::App*> visible_subcommands(const CLI::App& app) {
  return app.get_subcommands([](const CLI::App* a) { return !a->get_group().empty(); });
}

// As CLI11's own help: a flag has no type name (and its type size is 0 or -1).
bool takes_value(const CLI::Option& o) { return o.get_type_size_min() > 0 && !o.get_type_name().empty(); }

std::string metavar(const CLI::Option& o) {
  std::string t = o.get_type_name();
  t = t.substr(0, t.find(':'));
  return t.empty() ? "VALUE" : t;
}

bool numeric(const CLI::Option& o) {
  const std::string t = metavar(o);
  return t == "INT" || t == "UINT" || t == "FLOAT" || t == "NUMBER" || t == "FLOAT:POSITIVE";
}

std::vector<std::string> names(const CLI::Option& o) {
  std::vector<std::string> n;
  for (const auto& s : o.get_snames()) n.push_back("-" + s);
  for (const auto& l : o.get_lnames()) n.push_back("--" + l);
  return n;
}

// The words of a command path: {} for the program, {"sequence", "plan"} below it.
std::vector<std::string> path_of(const CLI::App& app) {
  std::vector<std::string> p;
  for (const CLI::App* a = &app; a->get_parent() != nullptr; a = a->get_parent()) p.insert(p.begin(), a->get_name());
  return p;
}
std::string join(const std::vector<std::string>& v, std::string_view sep) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : std::string(sep)) + x;
  return s;
}

void append_utf8_escaped(std::string& out, std::string_view text, std::size_t& i) {
  const auto c = static_cast<unsigned char>(text[i]);
  const int len = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : c >= 0xC0 ? 2 : 1;
  unsigned cp = len == 1 ? c : c & (0x7F >> len);
  for (int k = 1; k < len && i + k < text.size(); ++k) cp = (cp << 6) | (static_cast<unsigned char>(text[i + k]) & 0x3F);
  i += len - 1;
  out += len == 1 ? std::string("?") : fmt::format("\\[u{:04X}]", cp);
}

// One line of running text as roff (no request at its start).
std::string roff_line(std::string_view line) {
  std::string s = roff_escape(line);
  if (!s.empty() && (s[0] == '.' || s[0] == '\'')) s = "\\&" + s;
  return s;
}

// Plain text (paragraphs split by blank lines; lines starting with two spaces kept as they are).
void roff_text(std::string& out, std::string_view text) {
  std::istringstream in{std::string(text)};
  std::string line;
  bool in_nf = false, paragraph = true;
  while (std::getline(in, line)) {
    if (line.empty()) {
      if (in_nf) out += ".fi\n.RE\n";
      in_nf = false;
      paragraph = true;
      continue;
    }
    const bool literal = line.rfind("  ", 0) == 0;
    if (literal && !in_nf) {
      out += paragraph ? ".PP\n" : "";
      out += ".RS 2\n.nf\n";
      in_nf = true;
    } else if (!literal && in_nf) {
      out += ".fi\n.RE\n";
      in_nf = false;
      paragraph = true;
    }
    if (!literal && paragraph) out += ".PP\n";
    paragraph = false;
    out += roff_line(literal ? std::string_view(line).substr(2) : std::string_view(line)) + "\n";
  }
  if (in_nf) out += ".fi\n.RE\n";
}

std::string option_term(const CLI::Option& o) {
  std::string t;
  if (o.get_positional()) return "\\fI" + roff_escape(o.get_name(true)) + "\\fR";
  for (const auto& n : names(o)) t += (t.empty() ? "" : ", ") + ("\\fB" + roff_escape(n) + "\\fR");
  if (takes_value(o)) t += " \\fI" + roff_escape(metavar(o)) + "\\fR";
  return t;
}

void roff_options(std::string& out, const CLI::App& app) {
  const auto opts = visible_options(app);
  std::vector<std::string> groups;
  for (const auto* o : opts)
    if (std::find(groups.begin(), groups.end(), o->get_group()) == groups.end()) groups.push_back(o->get_group());
  for (const auto& g : groups) {
    if (groups.size() > 1) out += ".PP\n\\fI" + roff_escape(g) + "\\fR\n";
    for (const auto* o : opts) {
      if (o->get_group() != g) continue;
      out += ".TP\n" + option_term(*o) + "\n";
      std::string d = o->get_description();
      if (!o->get_default_str().empty() && takes_value(*o) && d.find("default") == std::string::npos)
        d += " (default: " + o->get_default_str() + ")";
      out += roff_line(d.empty() ? "(no description)" : d) + "\n";
    }
  }
}

void roff_commands(std::string& out, const CLI::App& app) {
  for (const auto* sub : visible_subcommands(app)) {
    auto path = path_of(*sub);
    const CLI::App* top = sub;
    while (top->get_parent() != nullptr) top = top->get_parent();
    path.insert(path.begin(), top->get_name());
    std::string synopsis = join(path, " ");
    for (const auto* o : visible_options(*sub))
      if (o->get_positional()) synopsis += " " + std::string(o->get_required() ? "" : "[") + o->get_name(true) +
                                           (o->get_required() ? "" : "]");
    if (!visible_subcommands(*sub).empty()) synopsis += " SUBCOMMAND";
    out += ".SS \"" + roff_escape(synopsis) + "\"\n";
    roff_text(out, sub->get_description());
    roff_options(out, *sub);
    if (!sub->get_footer().empty()) roff_text(out, sub->get_footer());
    roff_commands(out, *sub);
  }
}

std::string upper(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

std::string header(const ManPage& page) {
  std::string out = fmt::format(".\\\" Generated by `{} docs`: do not edit.\n", page.name);
  out += fmt::format(".TH \"{}\" \"{}\" \"\" \"{}\" \"{}\"\n", roff_escape(upper(page.name)), page.section,
                     roff_escape(page.version), page.section == 5 ? "File Formats" : "User Commands");
  out += ".SH NAME\n" + roff_escape(page.name) + " \\- " + roff_escape(page.summary) + "\n";
  return out;
}

std::string trailer(const ManPage& page) {
  std::string out;
  for (const auto& s : page.sections) {
    out += ".SH \"" + roff_escape(upper(s.title)) + "\"\n";
    roff_text(out, s.text);
  }
  if (!page.see_also.empty()) {
    out += ".SH \"SEE ALSO\"\n";
    std::string line;
    for (const auto& s : page.see_also) {
      const auto paren = s.find('(');
      line += (line.empty() ? "" : ",\n") + (paren == std::string::npos
                                                  ? roff_escape(s)
                                                  : ".BR " + roff_escape(s.substr(0, paren)) + " " + s.substr(paren));
    }
    out += line + "\n";
  }
  return out;
}

// Bash: a single-quoted word.
std::string sq(std::string_view s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

struct CompletionTables {
  std::vector<std::pair<std::string, std::string>> subcommands, flags, values, positionals;
};

// The value of an option as the script's _NAME_value encodes it: "-" nothing, "f" files,
// "w:WORDS", "fw:WORDS" (words and files), "l:WORDS" (a comma-separated list of words).
std::string value_code(const CLI::Option& o) {
  if (const ValueHint* h = value_hint(&o)) {
    const std::string words = join(h->words, " ");
    if (words.empty()) return h->files ? "f" : "-";
    return std::string(h->files ? "fw:" : h->list ? "l:" : "w:") + words;
  }
  return numeric(o) ? "-" : "f";
}

void collect(const CLI::App& app, CompletionTables& t) {
  const std::string path = join(path_of(app), " ");
  std::vector<std::string> subs;
  for (const auto* s : visible_subcommands(app)) subs.push_back(s->get_name());
  if (!subs.empty()) t.subcommands.emplace_back(path, join(subs, " "));
  std::vector<std::string> flags, positional;
  // Options of the parents apply below them where the subcommand lets them fall through.
  for (const CLI::App* a = &app; a != nullptr; a = a->get_fallthrough() ? a->get_parent() : nullptr) {
    for (const auto* o : visible_options(*a)) {
      if (o->get_positional()) {
        if (a == &app) positional.push_back(value_code(*o));
        continue;
      }
      for (const auto& n : names(*o)) {
        if (std::find(flags.begin(), flags.end(), n) != flags.end()) continue;
        flags.push_back(n);
        if (takes_value(*o)) t.values.emplace_back(path + "|" + n, value_code(*o));
      }
    }
  }
  t.flags.emplace_back(path, join(flags, " "));
  if (!positional.empty()) {
    // Several positionals: the words of all of them, and files when any takes files.
    std::string words;
    bool files = false;
    for (const auto& p : positional) {
      files = files || p == "f" || p.rfind("fw:", 0) == 0;
      const auto colon = p.find(':');
      if (colon != std::string::npos) words += (words.empty() ? "" : " ") + p.substr(colon + 1);
    }
    t.positionals.emplace_back(path, words.empty() ? (files ? "f" : "-") : (files ? "fw:" : "w:") + words);
  }
  for (const auto* s : visible_subcommands(app)) collect(*s, t);
}

std::string case_function(const std::string& fn, const std::vector<std::pair<std::string, std::string>>& rows,
                          bool fail_otherwise) {
  std::string s = fn + "() {\n  case $1 in\n";
  for (const auto& [k, v] : rows) s += "    " + sq(k) + ") REPLY=" + sq(v) + " ;;\n";
  s += fail_otherwise ? "    *) return 1 ;;\n" : "    *) REPLY='' ;;\n";
  return s + "  esac\n}\n";
}

}  // namespace

void set_value_hint(const CLI::Option* option, ValueHint hint) { hints()[option] = std::move(hint); }

const ValueHint* value_hint(const CLI::Option* option) {
  const auto it = hints().find(option);
  return it == hints().end() ? nullptr : &it->second;
}

void set_value_hint_everywhere(CLI::App& app, std::string_view flag, const ValueHint& hint) {
  for (const auto* o : app.get_options())
    for (const auto& n : names(*o))
      if (n == flag) set_value_hint(o, hint);
  for (auto* sub : app.get_subcommands([](CLI::App*) { return true; })) set_value_hint_everywhere(*sub, flag, hint);
}

std::string roff_escape(std::string_view text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\\') out += "\\e";
    else if (c == '-') out += "\\-";
    else if (static_cast<unsigned char>(c) >= 0x80) append_utf8_escaped(out, text, i);
    else out += c;
  }
  return out;
}

std::string man_page(const CLI::App& app, const ManPage& page) {
  std::string out = header(page);
  out += ".SH SYNOPSIS\n.B " + roff_escape(page.name) + "\n";
  if (!visible_subcommands(app).empty()) out += ".I COMMAND\n";
  out += ".RI [ OPTIONS ]\n.SH DESCRIPTION\n";
  roff_text(out, app.get_description());
  if (!app.get_footer().empty()) roff_text(out, app.get_footer());
  out += ".SH OPTIONS\n";
  roff_options(out, app);
  out += ".SH COMMANDS\n";
  roff_commands(out, app);
  return out + trailer(page);
}

std::string man_page_entries(const ManPage& page, std::string_view description, const std::vector<ManEntry>& entries,
                             std::string_view entries_title) {
  std::string out = header(page) + ".SH DESCRIPTION\n";
  roff_text(out, description);
  out += ".SH \"" + roff_escape(upper(std::string(entries_title))) + "\"\n";
  std::string heading;
  for (const auto& e : entries) {
    if (e.heading != heading) out += ".SS \"" + roff_escape(e.heading) + "\"\n";
    heading = e.heading;
    out += ".TP\n\\fB" + roff_escape(e.term) + "\\fR\n";
    std::string body;
    roff_text(body, e.text);
    // .TP's body is the paragraph after its tag: drop the first .PP, keep later ones.
    if (body.rfind(".PP\n", 0) == 0) body = body.substr(4);
    out += body;
  }
  return out + trailer(page);
}

std::string bash_completion(const CLI::App& app) {
  CompletionTables t;
  collect(app, t);
  std::string name = app.get_name();
  std::string fn = "_" + name;
  std::replace(fn.begin(), fn.end(), '-', '_');
  std::string s = fmt::format(
      "# bash completion for {0} (written by `{0} docs bash-completion` from {0}'s options: do not edit)\n"
      "# Completes subcommands, flags, the values of flags (choices, files) and file arguments.\n\n",
      name);
  s += "# " + fn + "_subcommands PATH: the subcommands below the command path PATH (\"sequence\").\n";
  s += case_function(fn + "_subcommands", t.subcommands, false);
  s += "# " + fn + "_flags PATH: its flags.\n";
  s += case_function(fn + "_flags", t.flags, false);
  s += "# " + fn + "_value 'PATH|FLAG': what FLAG's value completes to (-: nothing, f: files, w:WORDS,\n"
       "# fw:WORDS and files, l:WORDS a comma-separated list); fails for a flag without a value.\n";
  s += case_function(fn + "_value", t.values, true);
  s += "# " + fn + "_positional PATH: what its arguments complete to (as " + fn + "_value).\n";
  s += case_function(fn + "_positional", t.positionals, false);
  s += fmt::format(R"({0}_reply() {{
  local code=$1 cur=$2 prefix=''
  case $code in
    ''|-) return 0 ;;
    f) compopt -o filenames 2>/dev/null; mapfile -t COMPREPLY < <(compgen -f -- "$cur") ;;
    w:*) mapfile -t COMPREPLY < <(compgen -W "${{code#w:}}" -- "$cur") ;;
    fw:*) compopt -o filenames 2>/dev/null
          mapfile -t COMPREPLY < <(compgen -W "${{code#fw:}}" -- "$cur"; compgen -f -- "$cur") ;;
    l:*) [[ $cur == *,* ]] && prefix=${{cur%,*}},
         mapfile -t COMPREPLY < <(compgen -P "$prefix" -W "${{code#l:}}" -- "${{cur##*,}}") ;;
  esac
}}

{0}() {{
  local cur=${{COMP_WORDS[COMP_CWORD]}} path='' i w REPLY
  COMPREPLY=()
  # The command path: the subcommands among the words before the cursor, skipping flags
  # and the values of flags that take one.
  for ((i = 1; i < COMP_CWORD; i++)); do
    w=${{COMP_WORDS[i]}}
    if [[ $w == -* ]]; then
      if [[ $w != *=* ]] && {0}_value "$path|$w"; then
        if ((i + 1 == COMP_CWORD)); then {0}_reply "$REPLY" "$cur"; return 0; fi
        ((i++))
      fi
      continue
    fi
    {0}_subcommands "$path"
    [[ " $REPLY " == *" $w "* ]] && path=${{path:+$path }}$w
  done
  if [[ $cur == --*=* ]] && {0}_value "$path|${{cur%%=*}}"; then
    local flag=${{cur%%=*}}
    {0}_reply "$REPLY" "${{cur#*=}}"
    COMPREPLY=("${{COMPREPLY[@]/#/$flag=}}")
    return 0
  fi
  if [[ $cur == -* ]]; then
    {0}_flags "$path"
    mapfile -t COMPREPLY < <(compgen -W "$REPLY" -- "$cur")
    return 0
  fi
  {0}_subcommands "$path"
  if [[ -n $REPLY ]]; then
    mapfile -t COMPREPLY < <(compgen -W "$REPLY" -- "$cur")
    return 0
  fi
  {0}_positional "$path"
  {0}_reply "$REPLY" "$cur"
}}
complete -F {0} {1}
)",
                   fn, name);
  return s;
}

}  // namespace hdrd::cli
