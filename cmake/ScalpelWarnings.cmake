# Warnings are a target of their own: link scalpel::warnings PRIVATE to opt a target in.
add_library(scalpel_warnings INTERFACE)
add_library(scalpel::warnings ALIAS scalpel_warnings)
target_compile_options(scalpel_warnings INTERFACE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor)
if(SCALPEL_WARNINGS_AS_ERRORS)
  target_compile_options(scalpel_warnings INTERFACE -Werror)
endif()

# Options shared by every scalpel library.
add_library(scalpel_options INTERFACE)
add_library(scalpel::options ALIAS scalpel_options)
target_include_directories(scalpel_options INTERFACE ${PROJECT_SOURCE_DIR})
if(SCALPEL_VALIDATE)
  target_compile_definitions(scalpel_options INTERFACE SCALPEL_VALIDATE=1)
endif()
