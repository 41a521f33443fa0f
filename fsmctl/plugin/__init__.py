"""fsmctl/plugin"""
