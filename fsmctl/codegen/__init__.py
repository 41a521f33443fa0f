"""fsmctl/codegen"""
