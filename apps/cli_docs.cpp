// meshmark generate man|bash-completion: the man page and the bash completion, written from the
// same option tables as --help (the CLI11 app itself), so that neither can drift from it.

#include <fmt/format.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "cli.h"
#include "meshmark/version.h"

namespace meshmark::cli {

namespace {

std::vector<const CLI::App*> commands_of(const CLI::App& app) {
  return app.get_subcommands([](const CLI::App* c) { return !c->get_group().empty(); });
}

// The option names of a command and of its own subcommands, each once, in table order.
std::string option_words(const CLI::App& app, bool with_subcommands = true) {
  std::vector<std::string> words;
  auto add = [&](const std::string& w) {
    if (std::find(words.begin(), words.end(), w) == words.end()) words.push_back(w);
  };
  auto add_options = [&](const CLI::App& a) {
    for (const CLI::Option* o : a.get_options()) {
      for (const std::string& n : o->get_lnames()) add("--" + n);
      for (const std::string& n : o->get_snames()) add("-" + n);
    }
  };
  add_options(app);
  if (with_subcommands)
    for (const CLI::App* sub : commands_of(app)) add_options(*sub);
  std::string out;
  for (const std::string& w : words) out += (out.empty() ? "" : " ") + w;
  return out;
}

std::string command_words(const CLI::App& app) {
  std::string out;
  for (const CLI::App* sub : commands_of(app)) out += (out.empty() ? "" : " ") + sub->get_name();
  return out;
}

// roff text: backslashes and hyphens escaped, a line never starting with a control character.
std::string roff(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '\\')
      out += "\\e";
    else if (c == '-')
      out += "\\-";
    else if (c == '\n')
      out += "\n.br\n";
    else
      out += c;
  }
  return out.empty() || (out[0] != '.' && out[0] != '\'') ? out : "\\&" + out;
}

std::string man_options(const CLI::App& app) {
  std::string s;
  for (const CLI::Option* o : app.get_options()) {
    std::string name = o->get_name(true, true);
    if (o->get_expected_max() > 0 && o->nonpositional() && !o->get_type_name().empty())
      name += " " + o->get_type_name();
    s += ".TP\n.B " + roff(name) + "\n" + roff(o->get_description()) + "\n";
  }
  return s;
}

std::string man_page(const CLI::App& app) {
  std::string s = fmt::format(
      ".TH MESHMARK 1 \"\" \"meshmark {}\" \"User Commands\"\n.SH NAME\nmeshmark \\- {}\n"
      ".SH SYNOPSIS\n.B meshmark\n.I COMMAND\n[\\fIOPTIONS\\fR]\n.SH DESCRIPTION\n{}\n.PP\n"
      "Each command's options follow; \\fBmeshmark COMMAND \\-\\-help\\fR prints the same.\n",
      MESHMARK_VERSION_STRING, roff("hide a buyer's ID in a triangle mesh and trace leaks"),
      roff(app.get_description()));
  s += ".SH COMMANDS\n";
  for (const CLI::App* c : commands_of(app)) {
    s += ".SS " + roff(c->get_name()) + "\n" + roff(c->get_description()) + "\n";
    s += man_options(*c);
    for (const CLI::App* sub : commands_of(*c)) {
      s += ".TP\n.B " + roff(c->get_name() + " " + sub->get_name()) + "\n" +
           roff(sub->get_description()) + "\n.RS\n" + man_options(*sub) + ".RE\n";
    }
  }
  s += ".SH EXIT STATUS\n" + roff(app.get_footer()) + "\n";
  s += ".SH SEE ALSO\nThe pages of docs/ in meshmark's sources, rendered by the meshmark_doc "
       "target.\n";
  return s;
}

std::string bash_completion(const CLI::App& app) {
  std::string cases;
  for (const CLI::App* c : commands_of(app))
    cases += fmt::format("    {}) words=\"{}\" subs=\"{}\" ;;\n", c->get_name(), option_words(*c),
                         command_words(*c));
  return fmt::format(
      "# bash completion for meshmark {0}, generated from its option tables (meshmark generate "
      "bash-completion)\n"
      "_meshmark() {{\n"
      "  local cur=\"${{COMP_WORDS[COMP_CWORD]}}\" words subs\n"
      "  if [ \"$COMP_CWORD\" -eq 1 ]; then\n"
      "    COMPREPLY=($(compgen -W \"{1} {3}\" -- \"$cur\"))\n"
      "    return\n"
      "  fi\n"
      "  case \"${{COMP_WORDS[1]}}\" in\n{2}"
      "    *) words=\"\" subs=\"\" ;;\n"
      "  esac\n"
      "  if [[ \"$COMP_CWORD\" -eq 2 && -n \"$subs\" && \"$cur\" != -* ]]; then\n"
      "    COMPREPLY=($(compgen -W \"$subs\" -- \"$cur\"))\n"
      "  elif [[ \"$cur\" == -* ]]; then\n"
      "    COMPREPLY=($(compgen -W \"$words\" -- \"$cur\"))\n"
      "  else\n"
      "    COMPREPLY=($(compgen -f -- \"$cur\"))\n"
      "  fi\n"
      "}}\n"
      "complete -o filenames -F _meshmark meshmark\n",
      MESHMARK_VERSION_STRING, command_words(app), cases, option_words(app, false));
}

}  // namespace

void register_generate(CLI::App& app, int& exit_code) {
  auto what = std::make_shared<std::string>();
  CLI::App* sub = app.add_subcommand(
      "generate", "Print the man page (man) or the bash completion (bash-completion)");
  sub->group("");  // not listed in --help: a build step
  sub->add_option("WHAT", *what, "man or bash-completion")
      ->required()
      ->check(CLI::IsMember({"man", "bash-completion"}));
  sub->callback([&app, what, &exit_code] {
    fmt::print("{}", *what == "man" ? man_page(app) : bash_completion(app));
    exit_code = kOk;
  });
}

}  // namespace meshmark::cli
