# Writes OUT, a C++ header holding each file of FILES (in DIR) as a std::string_view named
# k<file name with '.' and '-' as '_'>, for files the program writes out as they are (the page of
# `amhv view`). Run by cmake -P at build time.
set(text "#pragma once\n// Generated from ${DIR} by tools/embed_text.cmake: do not edit.\n#include <string_view>\n\nnamespace amhv::embedded {\n")
foreach(name ${FILES})
  file(READ "${DIR}/${name}" content)
  string(MAKE_C_IDENTIFIER "${name}" id)
  string(APPEND text "inline constexpr std::string_view k_${id} = R\"amhv_embedded(${content})amhv_embedded\";\n")
endforeach()
string(APPEND text "}  // namespace amhv::embedded\n")
file(WRITE "${OUT}" "${text}")
