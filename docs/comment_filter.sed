# Doxygen's input filter (docs/Doxyfile.in) for the headers' /// comments: "#V" (a count, as in
# "#V x 3") and "\xNN" (an escape shown as text) are written as text, not as a link request or
# a command.
/\/\/\//{
s/\([^\\]\)#\([A-Za-z]\)/\1\\#\2/g
s/\\x/\\\\x/g
}
