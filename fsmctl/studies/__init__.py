"""fsmctl/studies"""
