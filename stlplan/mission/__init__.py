"""Reading a mission: the schema, the YAML document, loading and semantic checks."""
