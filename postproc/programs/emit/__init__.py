"""Writing programs: splice changed numbers into the original text, or write a new program."""
